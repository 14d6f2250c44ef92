"""Body-orientation hint (movingcam eq. 7): signed angle of the pelvis->neck vector from image up."""
import math

import numpy as np
import pytest

from services.pose import KEYPOINT_NAMES
from services.reconstruction.orientation_hint import orientation_hint

HIPS, SHOULDERS = (23, 24), (11, 12)


def _body(angle: float, centre=(320.0, 240.0), length=100.0) -> np.ndarray:
    """33 keypoints with hips around `centre` and shoulders `length` px along a body axis
    turned `angle` clockwise on screen from straight up."""
    points = np.tile(np.asarray(centre, float), (33, 1))
    up = np.array([math.sin(angle), -math.cos(angle)])  # y down
    side = np.array([-up[1], up[0]]) * 20.0
    points[HIPS[0]], points[HIPS[1]] = points[HIPS[0]] + side, points[HIPS[1]] - side
    points[SHOULDERS[0]] = np.asarray(centre) + up * length + side * 1.5
    points[SHOULDERS[1]] = np.asarray(centre) + up * length - side * 1.5
    return points


@pytest.mark.parametrize("degrees", [0.0, 30.0, -45.0, 90.0, 179.0, -120.0])
def test_angle_from_image_up_to_the_body_axis(degrees):
    angle, confidence = orientation_hint(_body(math.radians(degrees))[None], np.ones((1, 33)), KEYPOINT_NAMES)
    assert math.degrees(angle[0]) == pytest.approx(degrees, abs=1e-6)
    assert confidence[0] == 1.0


def test_leaning_right_on_screen_is_positive_and_confidence_is_the_weakest_landmark():
    keypoints = np.stack([_body(0.3), _body(-0.3)])
    visibility = np.ones((2, 33))
    visibility[1, SHOULDERS[1]] = 0.2
    visibility[0, 0] = 0.0  # the nose plays no part
    angle, confidence = orientation_hint(keypoints, visibility, KEYPOINT_NAMES)
    assert angle[0] > 0 > angle[1]
    np.testing.assert_allclose(confidence, [1.0, 0.2])
    # the neck is on the right of the pelvis in pixels when leaning right
    assert keypoints[0, SHOULDERS, 0].mean() > keypoints[0, HIPS, 0].mean()
