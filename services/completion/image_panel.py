"""The left half of the video: the still image with BlazePose's 2D keypoints drawn on it,
scaled to the video height (letterboxed when very wide)."""
from __future__ import annotations

import cv2
import numpy as np

from services.pose.track import KEYPOINT_NAMES

# Limbs drawn between landmarks; the person's left in orange, right in blue, the trunk in white.
_LEFT, _RIGHT, _MIDDLE = (255, 150, 30), (40, 150, 255), (240, 240, 240)
_BONES = (
    ("left_shoulder", "right_shoulder", _MIDDLE), ("left_hip", "right_hip", _MIDDLE),
    ("left_shoulder", "left_hip", _LEFT), ("right_shoulder", "right_hip", _RIGHT),
    ("left_shoulder", "left_elbow", _LEFT), ("left_elbow", "left_wrist", _LEFT),
    ("right_shoulder", "right_elbow", _RIGHT), ("right_elbow", "right_wrist", _RIGHT),
    ("left_hip", "left_knee", _LEFT), ("left_knee", "left_ankle", _LEFT),
    ("left_ankle", "left_heel", _LEFT), ("left_heel", "left_foot_index", _LEFT),
    ("right_hip", "right_knee", _RIGHT), ("right_knee", "right_ankle", _RIGHT),
    ("right_ankle", "right_heel", _RIGHT), ("right_heel", "right_foot_index", _RIGHT),
    ("left_ear", "left_eye", _LEFT), ("right_ear", "right_eye", _RIGHT), ("left_eye", "nose", _LEFT),
    ("right_eye", "nose", _RIGHT),
)
_BONE_INDEX = np.array([(KEYPOINT_NAMES.index(a), KEYPOINT_NAMES.index(b)) for a, b, _ in _BONES])


def panel_width(image_size: tuple[int, int], height: int, max_width: int) -> int:
    """Even width of the image scaled to `height`, at most `max_width`."""
    width, image_height = image_size
    scaled = int(round(width * height / image_height))
    return max(2, min(max_width, scaled) // 2 * 2)


def draw_image_panel(image_rgb: np.ndarray, keypoints: np.ndarray, visibility: np.ndarray, height: int,
                     max_width: int, min_visibility: float) -> np.ndarray:
    """(height, width, 3) uint8: the image scaled to fit (aspect kept, black bars if too wide),
    keypoints (33, 2) image pixels drawn on it; landmarks below `min_visibility` hollow."""
    image_height, image_width = image_rgb.shape[:2]
    width = panel_width((image_width, image_height), height, max_width)
    scale = min(height / image_height, width / image_width)
    shown = (max(1, int(round(image_width * scale))), max(1, int(round(image_height * scale))))
    panel = np.zeros((height, width, 3), np.uint8)
    left, top = (width - shown[0]) // 2, (height - shown[1]) // 2
    panel[top:top + shown[1], left:left + shown[0]] = cv2.resize(image_rgb, shown, interpolation=cv2.INTER_AREA)
    points = keypoints * scale + np.array([left, top])
    thickness = max(1, round(height / 240))
    pixel = lambda p: (int(round(p[0])), int(round(p[1])))
    for (a, b), (_, _, colour) in zip(_BONE_INDEX, _BONES):
        cv2.line(panel, pixel(points[a]), pixel(points[b]), colour, thickness, cv2.LINE_AA)
    radius = thickness + 2
    for point, seen in zip(points, visibility):
        cv2.circle(panel, pixel(point), radius, (255, 230, 0), -1 if seen >= min_visibility else thickness, cv2.LINE_AA)
    return panel
