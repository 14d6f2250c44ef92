"""Sliding time windows of at most three objects (002 §5.3, Fig. 8).

The paper learns one policy per short window in which the actor interacts with at most three
objects, the windows overlapping and visited in order. Policy n controls the character from
its contact with object n-1 to its contact with object n (its *control segment*), so it is
trained over the objects n-1, n and n+1: from the contact with object n-1 (the clip's start
for the first window) to the contact with object n+1 (the clip's end for the last). Window
n+1 starts where window n's control segment ends, so consecutive windows overlap by one
inter-contact stretch, and V_n(s(t_n), e) is the value of the stretch policy n+1 takes over
(the term eq. 15 subtracts).

With at most `max_objects` contacts in the clip one window covers it all (the paper's case
for clips with few objects: nothing is gained by cutting). The events are (frame, box) pairs
in time order; an object contacted twice appears twice (the paper: "the ordering of the
objects may be different from their unique IDs").

Deviation: the paper parameterises the middle object of a window relative to the previous
one; here every window sees the whole scene vector in absolute terms (the scene's own
[along, height] per box) and the fit optimises it jointly, which the windows' value functions
constrain only through the boxes they contain.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from learner.errors import SfvError

MAX_OBJECTS = 3
# PPO discount of the windows' trainings. Eq. 15 reads V_n(s(t_{n-1}), e) as the window's
# cumulative reward; with DeepMimic's gamma .95 (a 20-step horizon) the value at a window's
# first frame weighs a box contact 40 control steps in by .95^40 = .13, so the scene it
# depends on hardly moves it. .99 weighs it by .67.
WINDOW_GAMMA = 0.99


@dataclass(frozen=True)
class Window:
    index: int
    start: int  # first frame: the contact with the previous object (0 for the first window)
    control_end: int  # frame where the next window's policy takes over (t_n of eq. 15)
    end: int  # last frame trained: the next object's contact, or the clip's last frame
    boxes: tuple[int, ...]  # boxes contacted within [start, end]

    @property
    def frames(self) -> int:
        return self.end - self.start + 1

    def to_dict(self) -> dict:
        return {"index": self.index, "start": self.start, "control_end": self.control_end, "end": self.end,
                "boxes": list(self.boxes)}


def split_windows(num_frames: int, events: list[tuple[int, int]], max_objects: int = MAX_OBJECTS,
                  min_frames: int = 2) -> list[Window]:
    """The windows of a clip of `num_frames` frames with contacts `events` = [(frame, box), ...].

    Contacts closer than `min_frames` to the previous boundary are merged into it (two boxes
    touched in one step cannot start two windows)."""
    if num_frames < 2:
        raise SfvError(f"scene fit: a clip of {num_frames} frame(s) cannot be cut into windows")
    if max_objects < 1:
        raise SfvError(f"scene fit: at most {max_objects} objects per window is not a window")
    events = sorted((int(f), int(b)) for f, b in events)
    last = num_frames - 1
    for frame, box in events:
        if not 0 <= frame <= last:
            raise SfvError(f"scene fit: box {box}'s contact at frame {frame} lies outside the clip (0..{last})")
    if len(events) <= max_objects:
        return [Window(0, 0, last, last, tuple(sorted({b for _, b in events})))]
    contacts = _merge_close(events, min_frames, last)
    starts = [0] + [f for f, _ in contacts]  # window n starts at the contact with object n-1
    windows = []
    for n, (frame, _) in enumerate(contacts):
        start = starts[n]
        end = contacts[n + 1][0] if n + 1 < len(contacts) else last
        control_end = frame if n + 1 < len(contacts) else last
        boxes = tuple(sorted({b for f, b in events if start <= f <= end}))
        windows.append(Window(n, start, control_end, end, boxes))
    return windows


def _merge_close(events: list[tuple[int, int]], min_frames: int, last: int) -> list[tuple[int, int]]:
    """Contacts at least `min_frames` after the clip's start and after each other."""
    kept: list[tuple[int, int]] = []
    previous = 0
    for frame, box in events:
        if frame - previous >= min_frames and last - frame >= min_frames:
            kept.append((frame, box))
            previous = frame
    return kept or events[:1]


def proportional_contact_frames(alongs: np.ndarray, num_frames: int) -> np.ndarray:
    """Where no contact frame is given: box k is reached at the fraction of the clip that its
    position along the heading is of the span from the start (0) to beyond the farthest box.

    An approximation (constant speed along the heading): a root-free motion knows no path, so
    only the boxes' order and spacing are there to go by. The scene file may give each box's
    `frame` instead."""
    alongs = np.asarray(alongs, np.float64)
    if alongs.size == 0:
        return np.zeros(0, np.int64)
    span = max(float(alongs.max()), 1e-6) * (1.0 + 1.0 / (alongs.size + 1))
    fractions = np.clip(alongs / span, 0.0, 1.0)
    return np.round(fractions * (num_frames - 1)).astype(np.int64)

