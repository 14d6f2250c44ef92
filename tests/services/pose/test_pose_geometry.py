"""ROI construction, crop mapping, frame rotation and NMS: pure numpy/OpenCV."""
import math

import numpy as np
import pytest

from services.pose.detector import letterbox_matrix, weighted_nms
from services.pose.estimator import rotate_frame
from services.pose.roi import Roi, roi_from_alignment_points


def test_upright_person_gives_unrotated_roi_of_two_and_a_half_radii():
    roi = roi_from_alignment_points(np.array([100.0, 300.0]), np.array([100.0, 200.0]))
    assert (roi.centre_x, roi.centre_y) == (100.0, 300.0)
    assert roi.size == pytest.approx(2 * 100 * 1.25)
    assert roi.rotation == pytest.approx(0.0)


@pytest.mark.parametrize("lean_degrees", [-150.0, -30.0, 45.0, 90.0, 180.0])
def test_roi_crop_maps_the_scale_point_straight_above_the_centre(lean_degrees):
    centre = np.array([400.0, 500.0])
    lean = math.radians(lean_degrees)
    # body axis leaning `lean` clockwise from "up" in image coordinates (y down)
    scale_point = centre + 80.0 * np.array([math.sin(lean), -math.cos(lean)])
    roi = roi_from_alignment_points(centre, scale_point)
    crop_to_image = roi.crop_to_image(256)
    image_to_crop = np.linalg.inv(np.vstack([crop_to_image, [0, 0, 1]]))[:2]
    crop_centre = image_to_crop @ np.append(centre, 1)
    crop_scale_point = image_to_crop @ np.append(scale_point, 1)
    np.testing.assert_allclose(crop_centre, [128, 128], atol=1e-9)
    # 80 px in the image is 80 / (2 * 80 * 1.25) of the crop side, straight up
    np.testing.assert_allclose(crop_scale_point, [128, 128 - 256 / 2.5], atol=1e-9)


def test_roi_rotated_by_wraps_angle():
    assert Roi(0, 0, 10, 3.0).rotated_by(1.0).rotation == pytest.approx(4.0 - 2 * math.pi)


@pytest.mark.parametrize("degrees", [90, 180, 270])
def test_rotate_frame_back_matrix_maps_pixels_to_their_origin(degrees):
    image = np.zeros((5, 8, 3), np.uint8)
    image[1, 6] = (255, 0, 0)
    rotated, back = rotate_frame(image, degrees)
    y, x = np.argwhere(rotated[:, :, 0] == 255)[0]
    np.testing.assert_allclose(back @ [x, y, 1], [6, 1])
    # the linear part is a rotation by -degrees (y down), so 3D x/y can be turned back with it
    angle = -math.radians(degrees)
    np.testing.assert_allclose(back[:, :2], [[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]], atol=1e-12)


def test_letterbox_centres_a_portrait_frame():
    matrix = letterbox_matrix(1080, 1920)
    np.testing.assert_allclose(matrix @ [0, 0, 1], [(224 - 1080 * 224 / 1920) / 2, 0])
    np.testing.assert_allclose(matrix @ [1080, 1920, 1], [224 - (224 - 1080 * 224 / 1920) / 2, 224])


def test_weighted_nms_merges_overlaps_by_score_and_keeps_separate_boxes():
    boxes = np.array([[0, 0, 10, 10], [1, 0, 11, 10], [50, 50, 60, 60]], float)
    keypoints = np.array([[[0, 0]], [[3, 0]], [[55, 55]]], float)
    scores = np.array([0.9, 0.3, 0.6])
    merged = weighted_nms(scores, boxes, keypoints, iou_threshold=0.3)
    assert [m[0] for m in merged] == [0.9, 0.6]
    np.testing.assert_allclose(merged[0][1], [0.25, 0, 10.25, 10])
    np.testing.assert_allclose(merged[0][2], [[0.75, 0]])
    np.testing.assert_allclose(merged[1][1], boxes[2])
