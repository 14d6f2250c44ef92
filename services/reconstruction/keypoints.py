"""Which BlazePose landmarks correspond to which points of the humanoid.

The 12 output keypoints are the humanoid's hip, knee, ankle, shoulder, elbow and wrist
joints (link origins in `actors.character.skeleton`) named as in Pose2Sim / OpenPose marker files.
The fit also uses five auxiliary points that pin down rotations the 12 joints leave free:
the head centre (neck rotation) and each foot's toe and heel (ankle rotation). BlazePose's
"left" is the person's left, as is the humanoid's.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from actors.character.skeleton import LINK_NAMES, LINKS, yup_to_zup

JOINT_KEYPOINTS: tuple[str, ...] = (
    "RHip", "RKnee", "RAnkle", "LHip", "LKnee", "LAnkle",
    "RShoulder", "RElbow", "RWrist", "LShoulder", "LElbow", "LWrist",
)


@dataclass(frozen=True)
class FitPoint:
    name: str
    link: str  # humanoid link whose frame carries the point
    offset: tuple[float, float, float]  # in that link's frame, Z-up, metres
    blazepose: tuple[str, ...]  # landmarks averaged to give the observed point
    weight: float  # relative weight in the 2D loss


def _foot_box() -> tuple[np.ndarray, np.ndarray]:
    """Centre and half extents (Z-up, ankle frame) of the foot box, as `humanoid.py` builds it."""
    ankle = LINKS[LINK_NAMES.index("right_ankle")]
    ex, ey, ez = ankle.size
    return yup_to_zup(ankle.geom_offset_yup), np.array([ex, ez, ey]) / 2.0


FOOT_CENTRE, FOOT_HALF = _foot_box()
TOE_OFFSET = tuple(FOOT_CENTRE + FOOT_HALF * np.array([1.0, 0.0, -1.0]))
HEEL_OFFSET = tuple(FOOT_CENTRE + FOOT_HALF * np.array([-1.0, 0.0, -1.0]))
HEAD_OFFSET = tuple(yup_to_zup(LINKS[LINK_NAMES.index("neck")].geom_offset_yup))
ORIGIN = (0.0, 0.0, 0.0)

FIT_POINTS: tuple[FitPoint, ...] = (
    FitPoint("RHip", "right_hip", ORIGIN, ("right_hip",), 1.0),
    FitPoint("RKnee", "right_knee", ORIGIN, ("right_knee",), 1.0),
    FitPoint("RAnkle", "right_ankle", ORIGIN, ("right_ankle",), 1.0),
    FitPoint("LHip", "left_hip", ORIGIN, ("left_hip",), 1.0),
    FitPoint("LKnee", "left_knee", ORIGIN, ("left_knee",), 1.0),
    FitPoint("LAnkle", "left_ankle", ORIGIN, ("left_ankle",), 1.0),
    FitPoint("RShoulder", "right_shoulder", ORIGIN, ("right_shoulder",), 1.0),
    FitPoint("RElbow", "right_elbow", ORIGIN, ("right_elbow",), 1.0),
    FitPoint("RWrist", "right_wrist", ORIGIN, ("right_wrist",), 1.0),
    FitPoint("LShoulder", "left_shoulder", ORIGIN, ("left_shoulder",), 1.0),
    FitPoint("LElbow", "left_elbow", ORIGIN, ("left_elbow",), 1.0),
    FitPoint("LWrist", "left_wrist", ORIGIN, ("left_wrist",), 1.0),
    FitPoint("Head", "neck", HEAD_OFFSET, ("left_ear", "right_ear"), 0.5),
    FitPoint("RToe", "right_ankle", TOE_OFFSET, ("right_foot_index",), 0.5),
    FitPoint("RHeel", "right_ankle", HEEL_OFFSET, ("right_heel",), 0.5),
    FitPoint("LToe", "left_ankle", TOE_OFFSET, ("left_foot_index",), 0.5),
    FitPoint("LHeel", "left_ankle", HEEL_OFFSET, ("left_heel",), 0.5),
)
assert tuple(p.name for p in FIT_POINTS[: len(JOINT_KEYPOINTS)]) == JOINT_KEYPOINTS

FIT_NAMES: tuple[str, ...] = tuple(p.name for p in FIT_POINTS)
NUM_FIT = len(FIT_POINTS)
NUM_JOINT_KEYPOINTS = len(JOINT_KEYPOINTS)
FIT_LINKS = np.array([LINK_NAMES.index(p.link) for p in FIT_POINTS])
FIT_OFFSETS = np.array([p.offset for p in FIT_POINTS], dtype=np.float64)
FIT_WEIGHTS = np.array([p.weight for p in FIT_POINTS], dtype=np.float64)


def fit_index(name: str) -> int:
    return FIT_NAMES.index(name)


# Bones whose directions the per-frame fit of the 3D prediction matches (bone lengths differ
# between the person and the humanoid, directions do not). "pelvis" and "thorax" are the
# midpoints of the hips and of the shoulders.
FIT_BONES: tuple[tuple[str, str], ...] = (
    ("RHip", "LHip"), ("RHip", "RKnee"), ("RKnee", "RAnkle"), ("LHip", "LKnee"), ("LKnee", "LAnkle"),
    ("RShoulder", "LShoulder"), ("pelvis", "thorax"), ("thorax", "Head"),
    ("RShoulder", "RElbow"), ("RElbow", "RWrist"), ("LShoulder", "LElbow"), ("LElbow", "LWrist"),
    ("RHeel", "RToe"), ("LHeel", "LToe"),
)

# Swapping the person's left and right maps point i to point LEFT_RIGHT_SWAP[i].
LEFT_RIGHT_SWAP = np.array([FIT_NAMES.index(("L" + n[1:]) if n[0] == "R" else ("R" + n[1:]) if n[0] == "L" else n)
                            for n in FIT_NAMES])


def blazepose_matrix(keypoint_names: tuple[str, ...]) -> np.ndarray:
    """(NUM_FIT, len(keypoint_names)) averaging weights: observed fit points = M @ landmarks."""
    matrix = np.zeros((NUM_FIT, len(keypoint_names)))
    for row, point in enumerate(FIT_POINTS):
        for landmark in point.blazepose:
            matrix[row, keypoint_names.index(landmark)] = 1.0 / len(point.blazepose)
    return matrix


@dataclass
class ObservedPoints:
    """A pose track reduced to the fit points."""

    keypoints2d: np.ndarray  # (T, P, 2) pixels
    confidence: np.ndarray  # (T, P) in [0, 1]; 0 on frames without a person
    points3d: np.ndarray  # (T, P, 3) metres, camera axes (x right, y down, z away), hip-centred
    valid: np.ndarray  # (T,) bool

    def __len__(self) -> int:
        return len(self.valid)


def observe(track) -> ObservedPoints:
    """Map a `services.pose.PoseTrack` (BlazePose's 33 landmarks) onto the fit points.

    An averaged point's confidence is the smallest of its landmarks' confidences.
    """
    names = tuple(track.keypoint_names)
    matrix = blazepose_matrix(names)
    confidence = np.asarray(track.confidence, dtype=np.float64)
    point_conf = np.stack([confidence[:, [names.index(n) for n in p.blazepose]].min(axis=1) for p in FIT_POINTS], axis=1)
    valid = np.asarray(track.valid, dtype=bool)
    point_conf[~valid] = 0.0
    return ObservedPoints(
        keypoints2d=np.einsum("pk,tkd->tpd", matrix, np.asarray(track.keypoints2d, dtype=np.float64)),
        confidence=np.clip(point_conf, 0.0, 1.0),
        points3d=np.einsum("pk,tkd->tpd", matrix, np.asarray(track.world3d, dtype=np.float64)),
        valid=valid,
    )
