"""Body-orientation hint from 2D keypoints (Yu, Park & Lee 2021, "movingcam", Fig. 6, eq. 7).

Per frame, the signed angle between the image's up direction v_Y and the 2D body up-vector
v_b from the pelvis to the neck. The paper takes OpenPose's pelvis and neck joints;
BlazePose has neither, so the pelvis is the midpoint of the hips and the neck the midpoint
of the shoulders (OpenPose's neck lies there too). The paper assumes a camera that does not
roll, so the angle hints at the body's up-vector in 3D; the reward r_ori = exp(-a |h - h_sim|^2)
compares it with the simulated pelvis-to-head angle. Sign: positive when the body leans
towards the image's right (clockwise on screen), 0 upright, +-pi upside down.
Confidence: the smallest visibility of the four landmarks (0 on frames without the person,
and where one of them lies outside the picture).
"""
from __future__ import annotations

import numpy as np

HINT_LANDMARKS = ("left_hip", "right_hip", "left_shoulder", "right_shoulder")


def orientation_hint(keypoints2d: np.ndarray, confidence: np.ndarray, keypoint_names: tuple[str, ...],
                     image_size: tuple[int, int] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(T,) angles in radians and (T,) confidences from (T, K, 2) pixels and (T, K) visibility;
    with `image_size` (width, height), frames where one of the four lies outside the picture
    (BlazePose guesses them there) get confidence 0."""
    left_hip, right_hip, left_shoulder, right_shoulder = (keypoint_names.index(n) for n in HINT_LANDMARKS)
    points = np.asarray(keypoints2d, dtype=np.float64)
    pelvis = (points[:, left_hip] + points[:, right_hip]) / 2.0
    neck = (points[:, left_shoulder] + points[:, right_shoulder]) / 2.0
    up = neck - pelvis
    # image y points down: "up" is -y, so the angle from (0, -1) to (x, y) is atan2(x, -y)
    angle = np.arctan2(up[:, 0], -up[:, 1])
    used = [left_hip, right_hip, left_shoulder, right_shoulder]
    weakest = np.asarray(confidence, dtype=np.float64)[:, used].min(axis=1)
    if image_size is not None:
        inside = ((points[:, used] >= 0) & (points[:, used] <= np.asarray(image_size, np.float64) - 1)).all(axis=(1, 2))
        weakest = np.where(inside, weakest, 0.0)
    return angle, weakest
