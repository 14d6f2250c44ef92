"""Every person in consecutive frames: one BlazePose track per person, identities kept.

Each frame, every live track follows its ROI from the previous frame's auxiliary landmarks
(MediaPipe's tracking), as the single-person estimator does; every `detect_interval`
frames (and whenever nobody is tracked) the detector looks for people no track covers yet
and starts a track for each. Identity rules, chosen so that two people never become one:
- a track whose answer jumps (mean keypoint distance to its previous answer above
  `coherence_limit` x its ROI side) ends there: a switch to someone else is a gap, never
  a jump inside one identity;
- two tracks that converge onto the same person (their keypoint boxes overlap by more
  than `duplicate_iou`; two readings of one body differ in pose but not in extent) keep
  the older one; the newer one ends.
Where a track's answer is not confident it also tries its ROI turned by 90, 180 and 270
degrees (SFV section 5 trains with rotated images; the pretrained model is given rotated
crops at inference instead), keeping the most confident coherent answer. A frame where
nobody is tracked or detected upright is also searched turned by 90/180/270 degrees.
A new track's first answer is settled on its own frame: the detector's ROI (from face and hip
alignment points) is replaced by the one the landmarks give, until it stops moving
(`PeopleEstimator._settled`). On Pose2Sim two-people cam02 the woman seen from behind got, from the
detector's ROI, a body 591 px tall in frame 0 against 728-744 px in frames 1-5 as tracking
converged (her BlazePose 3D height 1.04 m, then 1.24, 1.29, 1.42, 1.45, 1.47): a subject who
has just appeared looked 20 % smaller, i.e. 0.4 m deeper, and the reference launched her
root 0.22 m toward the camera in its first frame.
Local track ids are per chunk; `services.pose.identity` joins them across chunks and gaps.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from services.pose.appearance import appearance_signature
from services.pose.config import PoseConfig
from services.pose.detector import PersonDetection
from services.pose.estimator import load_pose_models, roi_in_original, rotate_frame
from services.pose.landmarks import NUM_BODY_LANDMARKS, FramePose
from services.pose.models import PoseModelFiles
from services.pose.roi import Roi, normalize_radians, roi_from_alignment_points

FACE_LANDMARKS = slice(0, 11)  # nose .. mouth: the region the detector's box covers
TURNS = (90, 180, 270)


@dataclass(frozen=True)
class PersonEstimate:
    """One person's answer in one frame."""

    local_id: int
    pose: FramePose
    rotation_degrees: int
    appearance: np.ndarray | None = None  # clothes' colours (`appearance.py`), set by `PeopleEstimator.process`


@dataclass
class _Track:
    local_id: int
    roi: Roi
    previous: FramePose


def mean_keypoint_distance(a: FramePose, b: FramePose) -> float:
    return float(np.linalg.norm(a.keypoints[:NUM_BODY_LANDMARKS] - b.keypoints[:NUM_BODY_LANDMARKS], axis=1).mean())


def keypoint_box(pose: FramePose) -> np.ndarray:
    """x_min, y_min, x_max, y_max of the 33 body keypoints."""
    points = pose.keypoints[:NUM_BODY_LANDMARKS]
    return np.concatenate([points.min(axis=0), points.max(axis=0)])


def box_iou(a: np.ndarray, b: np.ndarray) -> float:
    inter = np.clip(np.minimum(a[2:], b[2:]) - np.maximum(a[:2], b[:2]), 0.0, None).prod()
    union = np.prod(a[2:] - a[:2]) + np.prod(b[2:] - b[:2]) - inter
    return float(inter / max(union, 1e-9))


def roi_change(before: Roi, after: Roi) -> float:
    """How far one ROI is from another, as a fraction of the first's side (centre shift plus
    side change; rotation counted as the arc it moves the ROI's corner by)."""
    shift = np.hypot(after.centre_x - before.centre_x, after.centre_y - before.centre_y)
    turn = abs(normalize_radians(after.rotation - before.rotation)) * 0.5
    return float((shift + abs(after.size - before.size)) / max(before.size, 1e-9) + turn)


class PeopleEstimator:
    """Stateful over consecutive frames of one chunk: the live tracks and the next local id."""

    def __init__(self, files: PoseModelFiles, config: PoseConfig | None = None):
        self.config = config = config or PoseConfig()
        self.detector, self.landmarks = load_pose_models(files, config, config.new_person_score_threshold)
        self._tracks: list[_Track] = []
        self._next_id = 0
        self._frame = 0

    def process(self, image_rgb: np.ndarray) -> list[PersonEstimate]:
        """Everyone found in the next frame (RGB uint8), oldest track first."""
        answers = [a for a in (self._follow(image_rgb, track) for track in self._tracks) if a is not None]
        answers = self._without_duplicates(answers)
        if not answers or self._frame % self.config.detect_interval == 0:
            answers += self._new_people(image_rgb, answers)
        if not answers:
            answers += self._new_people_turned(image_rgb)
        self._tracks = [_Track(a.local_id, a.pose.next_roi(), a.pose) for a in answers]
        self._frame += 1
        return self._with_appearance(image_rgb, answers)

    def _with_appearance(self, image_rgb: np.ndarray, answers: list[PersonEstimate]) -> list[PersonEstimate]:
        """Each answer with its clothes' signature, for `identity.py` to tell people apart. The
        tracker itself does not end a track on it: a person half behind a box changes colour as
        much as a track that slid onto someone else (tried on Pose2Sim two-people cam01 with a
        painted occluder: the man's track ended at frame 75 and came back as three)."""
        return [replace(a, appearance=appearance_signature(image_rgb, a.pose.keypoints, a.pose.visibility)) for a in answers]

    # ------------------------------------------------------------------ live tracks
    def _follow(self, image_rgb: np.ndarray, track: _Track) -> PersonEstimate | None:
        candidates = [(0, self.landmarks.estimate(image_rgb, track.roi))]
        if candidates[0][1].score < self.config.rotation_threshold:
            candidates += [(d, self.landmarks.estimate(image_rgb, track.roi.rotated_by(np.radians(d)))) for d in TURNS]
        limit = self.config.coherence_limit * track.previous.roi.size
        kept = [(d, p) for d, p in candidates if p.presence >= self.config.presence_threshold
                and mean_keypoint_distance(p, track.previous) <= limit]
        if not kept:
            return None  # lost, or jumped to someone else: the track ends here
        degrees, pose = max(kept, key=lambda c: c[1].score)
        return PersonEstimate(track.local_id, pose, degrees)

    def _is_duplicate(self, pose: FramePose, of: FramePose) -> bool:
        return box_iou(keypoint_box(pose), keypoint_box(of)) > self.config.duplicate_iou

    def _without_duplicates(self, answers: list[PersonEstimate]) -> list[PersonEstimate]:
        kept: list[PersonEstimate] = []
        for answer in sorted(answers, key=lambda a: a.local_id):  # lower id = older track
            if not any(self._is_duplicate(answer.pose, k.pose) for k in kept):
                kept.append(answer)
        return kept

    # ------------------------------------------------------------------ new people
    def _covered(self, detection: PersonDetection, answers: list[PersonEstimate]) -> bool:
        """The detection's face box lies on a face someone already tracked has."""
        centre = detection.box.reshape(2, 2).mean(axis=0)
        side = max(float(detection.box[2] - detection.box[0]), float(detection.box[3] - detection.box[1]), 1.0)
        return any(np.linalg.norm(a.pose.keypoints[FACE_LANDMARKS].mean(axis=0) - centre) < side for a in answers)

    def _settled(self, image_rgb: np.ndarray, pose: FramePose) -> FramePose:
        """`pose` re-estimated on the same frame from its own next ROI until the ROI moves by
        less than `settle_tolerance` of its side (at most `settle_rounds` times)."""
        for _ in range(self.config.settle_rounds):
            roi = pose.next_roi()
            if roi_change(pose.roi, roi) < self.config.settle_tolerance:
                break
            again = self.landmarks.estimate(image_rgb, roi)
            if again.presence < self.config.presence_threshold:
                break
            pose = again
        return pose

    def _start(self, pose: FramePose, degrees: int, answers: list[PersonEstimate],
               image_rgb: np.ndarray | None = None) -> PersonEstimate | None:
        if image_rgb is not None and pose.presence >= self.config.presence_threshold:
            pose = self._settled(image_rgb, pose)
        if pose.presence < self.config.presence_threshold or any(self._is_duplicate(pose, a.pose) for a in answers):
            return None
        self._next_id += 1
        return PersonEstimate(self._next_id - 1, pose, degrees)

    def _new_people(self, image_rgb: np.ndarray, answers: list[PersonEstimate]) -> list[PersonEstimate]:
        found: list[PersonEstimate] = []
        for detection in self.detector.detect_all(image_rgb):
            if self._covered(detection, answers + found):
                continue
            roi = roi_from_alignment_points(detection.keypoints[0], detection.keypoints[1])
            started = self._start(self.landmarks.estimate(image_rgb, roi), 0, answers + found, image_rgb)
            if started is not None:
                found.append(started)
        return found

    def _new_people_turned(self, image_rgb: np.ndarray) -> list[PersonEstimate]:
        """Nobody upright: the best person in the frame turned by 90, 180 or 270 degrees."""
        candidates = []
        for degrees in TURNS:
            rotated, back = rotate_frame(image_rgb, degrees)
            detection = self.detector.detect(rotated)
            if detection is None:
                continue
            roi = roi_from_alignment_points(detection.keypoints[0], detection.keypoints[1])
            pose = self.landmarks.estimate(rotated, roi)
            candidates.append((degrees, pose.transformed(back, roi_in_original(pose.roi, back, degrees))))
        present = [c for c in candidates if c[1].presence >= self.config.presence_threshold]
        if not present:
            return []
        degrees, pose = max(present, key=lambda c: c[1].score)
        started = self._start(pose, degrees, [], image_rgb)
        return [started] if started is not None else []
