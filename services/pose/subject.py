"""Everyone a video shows (`PeopleTrack`), and the one person a motion is made of.

Default subject: of the identities seen throughout (in at least SEEN_THROUGHOUT of the frames
the most-seen one is), the one that moves most (`activity.py`: the performer, not a bystander
who happens to be larger or first); ties go to the larger one (median ROI side).
`subject_reason` says which and why in one line, with the `--person` that changes it. `--person ID` names an identity as `sfv pose --people` lists it; `--person-at
X,Y@FRAME` the identity whose 2D keypoints' box holds pixel (X, Y) in that frame (the
nearest box centre when several do). The subject's PoseTrack has one row per frame of the
estimated range; frames where the subject is not seen are invalid and interpolated
(`fill_gaps`), never filled with another person's pose.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from learner.errors import SfvError
from services.pose.activity import person_activity
from services.pose.people_chunk import PeopleRows
from services.pose.track import PoseTrack, fill_gaps


@dataclass(frozen=True)
class PersonSummary:
    person: int
    frames_seen: int
    first_frame: int
    last_frame: int
    size_px: float  # median ROI side
    activity: float = 0.0  # body sizes per second (`activity.py`)


@dataclass
class PeopleTrack:
    """Every identity's answers for video frames start_frame .. start_frame + frame_count - 1."""

    fps: float
    image_size: tuple[int, int]
    start_frame: int
    frame_count: int
    rows: PeopleRows
    camera_homography: np.ndarray  # (frame_count, 3, 3) previous -> this frame; NaN where untracked
    camera_inliers: np.ndarray     # (frame_count,)

    def people(self) -> list[PersonSummary]:
        summaries = []
        for person in np.unique(self.rows.person):
            mine = self.rows.person == person
            frames = self.rows.frame[mine]
            size = float(np.median(self.rows.roi_size[mine]))
            activity = person_activity(frames, self.rows.keypoints2d[mine], self.rows.confidence[mine], size, self.fps)
            summaries.append(PersonSummary(int(person), int(mine.sum()), int(frames.min()), int(frames.max()), size,
                                           activity))
        return summaries


@dataclass(frozen=True)
class PersonChoice:
    """How to pick the subject: an id, a pixel at a frame, or (both None) the default."""

    person: int | None = None
    at: tuple[float, float, int] | None = None  # x, y, frame


def parse_person_at(text: str) -> tuple[float, float, int]:
    """'X,Y@FRAME' -> (x, y, frame); a one-line error naming the flag otherwise."""
    match = re.fullmatch(r"\s*([-+]?\d+(?:\.\d*)?)\s*,\s*([-+]?\d+(?:\.\d*)?)\s*@\s*(\d+)\s*", text)
    if not match:
        raise SfvError(f"--person-at {text!r}: expected X,Y@FRAME (pixels and a frame number, e.g. 320,240@10)")
    return float(match.group(1)), float(match.group(2)), int(match.group(3))


def parse_frames(text: str) -> tuple[int, int | None]:
    """'A:B' -> (A, B) (B exclusive; either may be empty: ':B', 'A:')."""
    match = re.fullmatch(r"\s*(\d*)\s*:\s*(\d*)\s*", text)
    if not match:
        raise SfvError(f"--frames {text!r}: expected A:B (first frame, frame after the last; e.g. 0:120)")
    start = int(match.group(1)) if match.group(1) else 0
    stop = int(match.group(2)) if match.group(2) else None
    if stop is not None and stop <= start:
        raise SfvError(f"--frames {text!r}: the end must come after the start")
    return start, stop


def choose_subject(people: PeopleTrack, choice: PersonChoice, source: str) -> int:
    summaries = people.people()
    if not summaries:
        raise SfvError(f"{source}: no person detected in any of {people.frame_count} frames")
    if choice.person is not None:
        known = [s.person for s in summaries]
        if choice.person not in known:
            raise SfvError(f"--person {choice.person}: no such person in {source} (ids {', '.join(map(str, known))}; "
                           "see `sfv pose --people PREVIEW.png`)")
        return choice.person
    if choice.at is not None:
        return _person_at(people, choice.at, source)
    return max(seen_throughout(summaries), key=lambda s: (s.activity, s.size_px)).person


# Seen in at least this share of the most-seen person's frames counts as seen throughout: a
# passer-by who walks out (70 of 100 frames in tests/people_clips.py) is not the subject however
# much they move, while an occlusion of a few frames (99 of 100 in Pose2Sim two-people) is no reason.
SEEN_THROUGHOUT = 0.8


def seen_throughout(summaries: list[PersonSummary]) -> list[PersonSummary]:
    most = max(s.frames_seen for s in summaries)
    return [s for s in summaries if s.frames_seen >= SEEN_THROUGHOUT * most]


def subject_reason(people: PeopleTrack, person: int, choice: PersonChoice) -> str:
    """One line: which person is the subject, why, and the flag that changes it."""
    summaries = {s.person: s for s in people.people()}
    chosen = summaries[person]
    if choice.person is not None or choice.at is not None:
        how = f"--person {choice.person}" if choice.person is not None else "--person-at"
        return f"subject: person {person} ({how}), seen in {chosen.frames_seen} of {people.frame_count} frames"
    others = [s for s in summaries.values() if s.person != person]
    if not others:
        return f"subject: person {person}, the only one seen ({chosen.frames_seen} of {people.frame_count} frames)"
    rivals = [s for s in seen_throughout(list(summaries.values())) if s.person != person]
    why = (f"seen throughout and moves most, {chosen.activity:.1f} body sizes/s against "
           + ", ".join(f"person {s.person}'s {s.activity:.1f}" for s in rivals)) if rivals else \
        f"seen longest ({chosen.frames_seen} of {people.frame_count} frames)"
    return (f"subject: person {person} of {len(summaries)} ({why}); "
            f"--person {' / '.join(str(s.person) for s in others)} follows another (`sfv pose --people SHEET.png` shows them)")


def _person_at(people: PeopleTrack, at: tuple[float, float, int], source: str) -> int:
    x, y, frame = at
    rows = people.rows
    here = np.flatnonzero(rows.frame == frame)
    if frame < people.start_frame or frame >= people.start_frame + people.frame_count:
        raise SfvError(f"--person-at {x:g},{y:g}@{frame}: frame {frame} is outside the estimated frames "
                       f"{people.start_frame}..{people.start_frame + people.frame_count - 1}")
    holding = []
    for i in here:
        low, high = rows.keypoints2d[i].min(axis=0), rows.keypoints2d[i].max(axis=0)
        if low[0] <= x <= high[0] and low[1] <= y <= high[1]:
            holding.append((float(np.linalg.norm((low + high) / 2 - (x, y))), int(rows.person[i])))
    if not holding:
        raise SfvError(f"--person-at {x:g},{y:g}@{frame}: nobody in {source} covers that pixel in frame {frame} "
                       f"({len(here)} people seen there)")
    return min(holding)[1]


def subject_track(people: PeopleTrack, person: int) -> PoseTrack:
    """The subject's PoseTrack over the estimated frames (see the module docstring)."""
    rows = people.rows.select(people.rows.person == person)
    frames = people.frame_count
    index = rows.frame - people.start_frame
    joints = rows.keypoints2d.shape[1]
    valid = np.zeros(frames, bool)
    valid[index] = True
    dense = {
        "keypoints2d": np.zeros((frames, joints, 2), np.float32), "confidence": np.zeros((frames, joints), np.float32),
        "world3d": np.zeros((frames, joints, 3), np.float32), "presence": np.zeros(frames, np.float32),
        "rotation_used": np.zeros(frames, np.int16),
    }
    for name, array in dense.items():
        array[index] = getattr(rows, name)
    return PoseTrack(
        fps=people.fps, image_size=people.image_size,
        keypoints2d=fill_gaps(dense["keypoints2d"], valid), confidence=dense["confidence"],
        world3d=fill_gaps(dense["world3d"], valid), valid=valid, presence=dense["presence"],
        rotation_used=dense["rotation_used"], filled_frames=int((~valid).sum()),
        start_frame=people.start_frame, person_id=person,
        camera_homography=people.camera_homography, camera_inliers=people.camera_inliers,
    )


MAX_MISSING_FRACTION = 0.5  # of the subject's span; more missing and the motion would be mostly guessed
# Longest gap a motion is interpolated across. Identities are joined across 3 s (identity.py), but
# a straight line through a hidden second is a pose nobody held: the Sports2D park demo's man is
# seen in frames 0-99, then 1 frame at 145 and 3 at 200-202, after jumping down from a 1.2 m box
# out of sight; filled across those 1.5 and 1.8 s gaps, its root moved 86 m/s between frames 200
# and 201 and the reference check could bring that only to 41 m/s. A walking person hidden behind a
# tree for a stride (about 1 s) is still joined.
MAX_GAP_S = 1.0


def seen_stretches(valid: np.ndarray, max_gap_frames: int) -> list[tuple[int, int]]:
    """[(first, stop)] of the runs of seen frames whose gaps are at most `max_gap_frames` long."""
    seen = np.flatnonzero(valid)
    if seen.size == 0:
        return []
    breaks = np.flatnonzero(np.diff(seen) - 1 > max_gap_frames)
    firsts = np.concatenate(([seen[0]], seen[breaks + 1]))
    lasts = np.concatenate((seen[breaks], [seen[-1]]))
    return [(int(a), int(b) + 1) for a, b in zip(firsts, lasts)]


def stretch_line(track: PoseTrack, stretches: list[tuple[int, int]], kept: tuple[int, int]) -> str:
    """One line: which stretch of the subject's frames the motion covers and why (video frames)."""
    fps, base = float(track.fps), track.start_frame
    gaps = [(stretches[i][1], stretches[i + 1][0]) for i in range(len(stretches) - 1)]
    unseen = ", ".join(f"{(b - a) / fps:.1f} s from frame {base + a}" for a, b in gaps)
    return (f"subject frames: {base + kept[0]}-{base + kept[1] - 1} (person {track.person_id} is unseen for {unseen}; "
            f"a gap over {MAX_GAP_S:g} s is not interpolated, and the motion covers the stretch seen longest); "
            "--frames A:B chooses another")


def crop_to_seen(track: PoseTrack, source: str, say=None) -> PoseTrack:
    """The track over the subject's longest stretch of seen frames (gaps up to MAX_GAP_S inside
    it stay interpolated; `say` gets one line when a longer gap cut the track). An SfvError when
    the subject is missing from most of it."""
    stretches = seen_stretches(track.valid, max(1, int(round(MAX_GAP_S * float(track.fps)))))
    if not stretches or int(track.valid.sum()) < 2:
        seen_count = int(track.valid.sum())
        raise SfvError(f"{source}: the subject (person {track.person_id}) is seen in {seen_count} frame(s); "
                       "a motion needs at least 2")
    first, stop = max(stretches, key=lambda s: (int(track.valid[s[0]:s[1]].sum()), -s[0]))
    if (stop - first) < 2:
        raise SfvError(f"{source}: the subject (person {track.person_id}) is seen for at most 1 frame in a row "
                       f"(gaps over {MAX_GAP_S:g} s cut the track); a motion needs at least 2")
    if len(stretches) > 1 and say is not None:
        say(stretch_line(track, stretches, (first, stop)))
    seen_count = int(track.valid[first:stop].sum())
    missing = (stop - first) - seen_count
    if missing > MAX_MISSING_FRACTION * (stop - first):
        raise SfvError(f"{source}: the subject (person {track.person_id}) is lost in {missing} of the {stop - first} "
                       f"frames it spans; choose --frames or another --person (see `sfv pose --people`)")
    window = slice(first, stop)
    return PoseTrack(
        fps=track.fps, image_size=track.image_size, keypoints2d=track.keypoints2d[window],
        confidence=track.confidence[window], world3d=track.world3d[window], valid=track.valid[window],
        presence=track.presence[window], rotation_used=track.rotation_used[window], filled_frames=missing,
        keypoint_names=track.keypoint_names, start_frame=track.start_frame + first, person_id=track.person_id,
        camera_homography=None if track.camera_homography is None else track.camera_homography[window],
        camera_inliers=None if track.camera_inliers is None else track.camera_inliers[window],
    )
