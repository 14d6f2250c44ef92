"""How much a person moves: the measure the default subject choice ranks people by.

activity = mean over the frames a person is seen in consecutively of
    (mean displacement of the confident body keypoints relative to the hip midpoint
     + displacement of the hip midpoint) / the person's median ROI side,
in body sizes per second. The performer moves limbs and travels; a bystander stands.
Pose2Sim two-people cam02 (both seen in 99-100 of 100 frames): the man balancing on the force
plates 4.0 /s, the woman standing in the foreground 0.7 /s, though she is the larger (ROI side
1123 px against 1014) and was chosen by size before.
"""
from __future__ import annotations

import numpy as np

BODY = slice(11, 33)  # shoulders .. feet (the face's landmarks say little about a performance)
HIPS = [23, 24]
MIN_CONFIDENCE = 0.5  # a keypoint moves only where it was read confidently at both frames


def person_activity(frames: np.ndarray, keypoints2d: np.ndarray, confidence: np.ndarray, roi_side: float,
                    fps: float) -> float:
    """Body sizes per second (see the module docstring) of one person's rows: frames (N,),
    keypoints2d (N, 33, 2) pixels, confidence (N, 33); 0 with fewer than two consecutive frames."""
    order = np.argsort(frames)
    frames, points, confident = frames[order], keypoints2d[order], confidence[order] >= MIN_CONFIDENCE
    pairs = np.flatnonzero(np.diff(frames) == 1)
    if pairs.size == 0 or roi_side <= 0:
        return 0.0
    hips = points[:, HIPS].mean(axis=1)
    relative = points[:, BODY] - hips[:, None]
    step = np.linalg.norm(relative[pairs + 1] - relative[pairs], axis=-1)
    both = confident[pairs][:, BODY] & confident[pairs + 1][:, BODY]
    limbs = (step * both).sum(axis=1) / np.maximum(both.sum(axis=1), 1)
    travel = np.linalg.norm(hips[pairs + 1] - hips[pairs], axis=-1)
    return float((limbs + travel).mean() / roi_side * fps)
