"""SSD anchors of the BlazePose detector (no model files needed)."""
import numpy as np

from services.pose.anchors import DETECTOR_INPUT_SIZE, ssd_anchor_centres


def test_anchor_count_matches_the_detector_output():
    assert ssd_anchor_centres().shape == (2254, 2)


def test_anchor_layout_is_three_feature_maps_in_row_major_order():
    anchors = ssd_anchor_centres()
    stride8, stride16, stride32 = anchors[:1568], anchors[1568:1960], anchors[1960:]
    # stride 8: 28x28 cells, 2 anchors per cell, x varies fastest
    np.testing.assert_allclose(stride8[0], [0.5 / 28, 0.5 / 28])
    np.testing.assert_allclose(stride8[1], stride8[0])
    np.testing.assert_allclose(stride8[2], [1.5 / 28, 0.5 / 28])
    np.testing.assert_allclose(stride8[56], [0.5 / 28, 1.5 / 28])
    # stride 16: 14x14 cells; the three stride-32 layers share one 7x7 map, 6 anchors per cell
    np.testing.assert_allclose(stride16[-1], [13.5 / 14, 13.5 / 14])
    np.testing.assert_allclose(stride32[:6], np.tile([0.5 / 7, 0.5 / 7], (6, 1)))
    np.testing.assert_allclose(stride32[6], [1.5 / 7, 0.5 / 7])
    assert len(np.unique(stride32, axis=0)) == 49


def test_anchor_centres_lie_inside_the_input():
    anchors = ssd_anchor_centres() * DETECTOR_INPUT_SIZE
    assert anchors.min() > 0 and anchors.max() < DETECTOR_INPUT_SIZE
