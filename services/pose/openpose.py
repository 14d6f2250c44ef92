"""Reading OpenPose JSON (one file per frame) to compare BlazePose against it.

Pose2Sim's sample writes OpenPose's BODY_25B layout; `BLAZEPOSE_FROM_BODY_25B` pairs
the limb joints that both skeletons name the same.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from learner.errors import SfvError

# BlazePose index -> BODY_25B index, for shoulders, elbows, wrists, hips, knees, ankles.
BLAZEPOSE_FROM_BODY_25B: dict[int, int] = {
    11: 5, 12: 6, 13: 7, 14: 8, 15: 9, 16: 10,
    23: 11, 24: 12, 25: 13, 26: 14, 27: 15, 28: 16,
}


def load_openpose_frame(path: str | Path) -> np.ndarray:
    """(people, joints, 3) array of x, y, confidence (confidence 0 = not found)."""
    path = Path(path)
    try:
        people = json.loads(path.read_text())["people"]
        joints = [np.reshape(p["pose_keypoints_2d"], (-1, 3)) for p in people]
        return np.array(joints, dtype=np.float64).reshape(len(people), -1, 3)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise SfvError(f"{path}: not an OpenPose keypoint JSON ({exc})") from exc


def matched_joint_errors(blazepose_xy: np.ndarray, openpose_people: np.ndarray,
                         pairs: dict[int, int] = BLAZEPOSE_FROM_BODY_25B) -> np.ndarray:
    """Pixel distance per paired joint to the OpenPose person closest to our pose
    (NaN where OpenPose did not find the joint or found nobody)."""
    ours = blazepose_xy[list(pairs.keys())]
    best = np.full(len(pairs), np.nan)
    best_mean = np.inf
    for person in openpose_people:
        theirs = person[list(pairs.values())]
        found = theirs[:, 2] > 0
        if not found.any():
            continue
        distance = np.where(found, np.linalg.norm(theirs[:, :2] - ours, axis=1), np.nan)
        mean = np.nanmean(distance)
        if mean < best_mean:
            best, best_mean = distance, mean
    return best
