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
from services.pose.activity import HIPS, MIN_CONFIDENCE, person_activity
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
# Longest gap a motion is interpolated across whatever happens in it. Identities are joined across
# 3 s (identity.py), but a straight line through a hidden second is a pose nobody held: the
# Sports2D park demo's man is seen in frames 0-99, then 1 frame at 145 and 3 at 200-202, after
# jumping down from a 1.2 m box out of sight; filled across those 1.5 and 1.8 s gaps, its root
# moved 86 m/s between frames 200 and 201 and the reference check could bring that only to 41 m/s.
MAX_GAP_S = 1.0
# A longer gap, up to the identity join's reach, is interpolated when the subject coasts across it:
# seen in at least COAST_MIN_SEEN frames within COAST_WINDOW_S on each side, the hip centre
# reappears within COAST_TOLERANCE body heights of where its image velocity on the two sides
# (their mean) takes it, and its size changes by less than COAST_SIZE_RATIO. Measured on the park
# walk behind a 300-px pole (`bench/scripts/video_encodings.py`, `pole`): hidden 1.03 s, 0.17 body
# heights off the line, so she is joined (before: the motion covered 69 of her frames); the man on
# the box is seen once after his 1.5-s gap, at 1.8 times his size, and stays cut.
MAX_COASTED_GAP_S = 3.0
COAST_WINDOW_S, COAST_MIN_SEEN = 0.5, 5
COAST_TOLERANCE, COAST_SIZE_RATIO = 0.3, 1.25


def _body_height_px(track: PoseTrack, frames: np.ndarray) -> float:
    """Median vertical extent of the confident keypoints over `frames` (0 when nothing is known)."""
    heights = []
    for frame in frames:
        confident = track.confidence[frame] >= MIN_CONFIDENCE
        points = track.keypoints2d[frame][confident] if confident.sum() >= 4 else track.keypoints2d[frame]
        heights.append(float(np.ptp(points[:, 1])))
    return float(np.median(heights)) if heights else 0.0


def _image_velocity(points: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """(2,) px per frame: the least-squares line through points[frames] (T, 2)."""
    design = np.column_stack((frames, np.ones(len(frames))))
    return np.linalg.lstsq(design, points[frames], rcond=None)[0][0]


def coasts_across(track: PoseTrack, last_seen: int, next_seen: int) -> bool:
    """Whether the subject moves on across the gap between frames `last_seen` and `next_seen` as
    it moved on either side of it (see MAX_COASTED_GAP_S)."""
    if (next_seen - last_seen) > MAX_COASTED_GAP_S * float(track.fps):
        return False
    window = max(2, int(round(COAST_WINDOW_S * float(track.fps))))
    seen = np.flatnonzero(track.valid)
    before = seen[(seen > last_seen - window) & (seen <= last_seen)]
    after = seen[(seen >= next_seen) & (seen < next_seen + window)]
    if min(len(before), len(after)) < COAST_MIN_SEEN:
        return False
    sizes = (_body_height_px(track, before), _body_height_px(track, after))
    if min(sizes) <= 0.0 or max(sizes) / min(sizes) > COAST_SIZE_RATIO:
        return False
    hips = track.keypoints2d[:, HIPS].astype(np.float64).mean(axis=1)
    velocity = (_image_velocity(hips, before) + _image_velocity(hips, after)) / 2
    miss = hips[next_seen] - hips[last_seen] - velocity * (next_seen - last_seen)
    return bool(np.linalg.norm(miss) <= COAST_TOLERANCE * max(sizes))


def seen_stretches(valid: np.ndarray, max_gap_frames: int, joins=None) -> list[tuple[int, int]]:
    """[(first, stop)] of the runs of seen frames whose gaps are at most `max_gap_frames` long
    or, longer, joined by `joins(last_seen, next_seen)`."""
    seen = np.flatnonzero(valid)
    if seen.size == 0:
        return []
    breaks = [i for i in np.flatnonzero(np.diff(seen) - 1 > max_gap_frames)
              if joins is None or not joins(int(seen[i]), int(seen[i + 1]))]
    breaks = np.asarray(breaks, dtype=np.int64)
    firsts = np.concatenate(([seen[0]], seen[breaks + 1]))
    lasts = np.concatenate((seen[breaks], [seen[-1]]))
    return [(int(a), int(b) + 1) for a, b in zip(firsts, lasts)]


def coasted_gaps(track: PoseTrack, first: int, stop: int, max_gap_frames: int) -> list[tuple[int, int]]:
    """[(first unseen, next seen)] of the gaps longer than `max_gap_frames` inside frames first..stop-1."""
    seen = np.flatnonzero(track.valid[first:stop]) + first
    return [(int(a) + 1, int(b)) for a, b in zip(seen[:-1], seen[1:]) if b - a - 1 > max_gap_frames]


def stretch_line(track: PoseTrack, stretches: list[tuple[int, int]], kept: tuple[int, int]) -> str:
    """One line: which stretch of the subject's frames the motion covers and why (video frames)."""
    fps, base = float(track.fps), track.start_frame
    gaps = [(stretches[i][1], stretches[i + 1][0]) for i in range(len(stretches) - 1)]
    unseen = ", ".join(f"{(b - a) / fps:.1f} s from frame {base + a}" for a, b in gaps)
    return (f"subject frames: {base + kept[0]}-{base + kept[1] - 1} (person {track.person_id} is unseen for {unseen}; "
            f"a gap over {MAX_GAP_S:g} s is not interpolated unless the person moves on across it as before, and the "
            "motion covers the stretch seen longest); --frames A:B chooses another")


def crop_to_seen(track: PoseTrack, source: str, say=None) -> PoseTrack:
    """The track over the subject's longest stretch of seen frames (gaps up to MAX_GAP_S inside
    it stay interpolated, and longer ones the subject coasts across; `say` gets one line when a
    longer gap cut the track, one when it was interpolated). An SfvError when the subject is
    missing from most of it."""
    max_gap = max(1, int(round(MAX_GAP_S * float(track.fps))))
    stretches = seen_stretches(track.valid, max_gap, lambda a, b: coasts_across(track, a, b))
    if stretches and _mostly_missing(track, _longest(track, stretches)):  # coasting would make it mostly guessed
        stretches = seen_stretches(track.valid, max_gap)
    if not stretches or int(track.valid.sum()) < 2:
        seen_count = int(track.valid.sum())
        raise SfvError(f"{source}: the subject (person {track.person_id}) is seen in {seen_count} frame(s); "
                       "a motion needs at least 2")
    first, stop = _longest(track, stretches)
    if (stop - first) < 2:
        raise SfvError(f"{source}: the subject (person {track.person_id}) is seen for at most 1 frame in a row "
                       f"(gaps over {MAX_GAP_S:g} s cut the track); a motion needs at least 2")
    if len(stretches) > 1 and say is not None:
        say(stretch_line(track, stretches, (first, stop)))
    coasted = coasted_gaps(track, first, stop, max_gap)
    if coasted and say is not None:
        fps, base = float(track.fps), track.start_frame
        say("subject gaps interpolated: person " + str(track.person_id) + " is unseen for "
            + ", ".join(f"{(b - a) / fps:.2f} s from frame {base + a}" for a, b in coasted)
            + f" (over {MAX_GAP_S:g} s, but moving on across it as before it)")
    if _mostly_missing(track, (first, stop)):
        missing = (stop - first) - int(track.valid[first:stop].sum())
        raise SfvError(f"{source}: the subject (person {track.person_id}) is lost in {missing} of the {stop - first} "
                       f"frames it spans; choose --frames or another --person (see `sfv pose --people`)")
    return track_window(track, first, stop)


def _longest(track: PoseTrack, stretches: list[tuple[int, int]]) -> tuple[int, int]:
    """The stretch with the most seen frames (the earlier one on a tie)."""
    return max(stretches, key=lambda s: (int(track.valid[s[0]:s[1]].sum()), -s[0]))


def _mostly_missing(track: PoseTrack, stretch: tuple[int, int]) -> bool:
    first, stop = stretch
    return (stop - first) - int(track.valid[first:stop].sum()) > MAX_MISSING_FRACTION * (stop - first)


def track_window(track: PoseTrack, first: int, stop: int) -> PoseTrack:
    """The track's frames first..stop-1 (its own row indices) as a track of their own."""
    window = slice(first, stop)
    return PoseTrack(
        fps=track.fps, image_size=track.image_size, keypoints2d=track.keypoints2d[window],
        confidence=track.confidence[window], world3d=track.world3d[window], valid=track.valid[window],
        presence=track.presence[window], rotation_used=track.rotation_used[window],
        filled_frames=int((~track.valid[window]).sum()),
        keypoint_names=track.keypoint_names, start_frame=track.start_frame + first, person_id=track.person_id,
        camera_homography=None if track.camera_homography is None else track.camera_homography[window],
        camera_inliers=None if track.camera_inliers is None else track.camera_inliers[window],
    )
