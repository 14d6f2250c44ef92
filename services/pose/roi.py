"""The rotated square region of interest that the landmark model looks at.

MediaPipe builds it from two alignment points (AlignmentPointsRectsCalculator followed
by RectTransformationCalculator): the centre is the first point, the side is twice the
distance to the second point, scaled by 1.25, and the rotation turns the first->second
vector to point straight up (target angle 90 degrees). For a detection the points are
keypoints 0 (mid-hip) and 1 (full-body circle); while tracking they are the landmark
model's auxiliary landmarks 33 and 34.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

ROI_SCALE = 1.25
TARGET_ANGLE = math.pi / 2


@dataclass(frozen=True)
class Roi:
    """Square region in image pixels: centre, side length, rotation (radians, image
    y axis pointing down; positive turns the region's up vector towards +x)."""

    centre_x: float
    centre_y: float
    size: float
    rotation: float

    def crop_to_image(self, crop_size: int) -> np.ndarray:
        """2x3 affine taking crop pixels (0..crop_size) to image pixels."""
        cos, sin = math.cos(self.rotation), math.sin(self.rotation)
        scale = self.size / crop_size
        linear = np.array([[cos, -sin], [sin, cos]]) * scale
        offset = np.array([self.centre_x, self.centre_y]) - linear @ np.array([crop_size / 2.0, crop_size / 2.0])
        return np.concatenate([linear, offset[:, None]], axis=1)

    def rotated_by(self, angle: float) -> Roi:
        return Roi(self.centre_x, self.centre_y, self.size, normalize_radians(self.rotation + angle))


def normalize_radians(angle: float) -> float:
    return angle - 2 * math.pi * math.floor((angle + math.pi) / (2 * math.pi))


def roi_from_alignment_points(centre: np.ndarray, scale_point: np.ndarray, scale: float = ROI_SCALE) -> Roi:
    """ROI centred on `centre`, side 2*|scale_point-centre|*scale, rotated so that
    centre->scale_point points up in the crop."""
    dx, dy = float(scale_point[0] - centre[0]), float(scale_point[1] - centre[1])
    side = 2.0 * math.hypot(dx, dy) * scale
    # y is flipped because the image y axis points down
    rotation = normalize_radians(TARGET_ANGLE - math.atan2(-dy, dx))
    return Roi(float(centre[0]), float(centre[1]), side, rotation)
