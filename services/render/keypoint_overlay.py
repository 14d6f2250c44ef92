"""2D keypoints drawn over video frames: the detected 12 joints and their bones (right side
orange, left blue), and any 3D points projected through a pinhole camera."""
from __future__ import annotations

import cv2
import numpy as np

from services.reconstruction.keypoints import JOINT_KEYPOINTS

BONES = (
    ("RHip", "RKnee"), ("RKnee", "RAnkle"), ("LHip", "LKnee"), ("LKnee", "LAnkle"), ("RHip", "LHip"),
    ("RShoulder", "LShoulder"), ("RShoulder", "RElbow"), ("RElbow", "RWrist"), ("LShoulder", "LElbow"),
    ("LElbow", "LWrist"), ("RShoulder", "RHip"), ("LShoulder", "LHip"),
)
RIGHT_COLOUR, LEFT_COLOUR, CENTRE_COLOUR, MODEL_COLOUR = (255, 80, 40), (40, 140, 255), (240, 240, 240), (60, 230, 60)
MIN_CONFIDENCE = 0.3


def draw_keypoints(frame: np.ndarray, keypoints: np.ndarray, confidence: np.ndarray, scale: np.ndarray,
                   colour_override=None, radius: int = 4, thickness: int = 2) -> None:
    """Draw the 12 joints (right side orange, left side blue, or one colour) and their bones
    onto frame; keypoints in pixels of the original video, scale = (sx, sy) to frame pixels."""
    points = np.round(keypoints * scale).astype(int)
    seen = confidence >= MIN_CONFIDENCE
    for a, b in BONES:
        i, j = JOINT_KEYPOINTS.index(a), JOINT_KEYPOINTS.index(b)
        if seen[i] and seen[j]:
            colour = colour_override or (RIGHT_COLOUR if a[0] == b[0] == "R" else LEFT_COLOUR if a[0] == b[0] == "L" else CENTRE_COLOUR)
            cv2.line(frame, tuple(points[i]), tuple(points[j]), colour, thickness, cv2.LINE_AA)
    for i, name in enumerate(JOINT_KEYPOINTS):
        if seen[i]:
            colour = colour_override or (RIGHT_COLOUR if name[0] == "R" else LEFT_COLOUR)
            cv2.circle(frame, tuple(points[i]), radius, colour, -1, cv2.LINE_AA)


def project(points: np.ndarray, rotation, position, intrinsics) -> np.ndarray:
    cam = (points - position) @ rotation.T
    return cam[..., :2] / np.maximum(cam[..., 2:], 1e-6) * np.diag(intrinsics)[:2] + intrinsics[:2, 2]
