"""The report's measures (`services/pipeline/metrics.py`, `report.py`) on cases whose answer is known."""
from __future__ import annotations

import numpy as np
import pytest

from actors.character.skeleton import JOINT_IS_SPHERICAL
from services.pipeline import metrics
from services.pipeline.report import motion_figures, video_rows
from services.pipeline.rollout import body_kinematics


def test_equal_motions_have_zero_joint_error_and_a_shift_shows_in_the_world_not_root_relative():
    rng = np.random.default_rng(0)
    joints = rng.normal(size=(10, 12, 3))
    assert np.array_equal(metrics.joint_position_errors(joints, joints), np.zeros(10))
    shifted = joints + np.array([0.3, -0.4, 0.0])  # 0.5 m away, every joint, every frame
    np.testing.assert_allclose(metrics.joint_position_errors(shifted, joints), 0.5)
    np.testing.assert_allclose(metrics.joint_position_errors(shifted, joints, centre=[0, 3]), 0.0, atol=1e-12)
    one = joints.copy()
    one[4, 2] += [0.0, 0.0, 1.2]  # one joint of one frame 1.2 m off: that frame's mean is 1.2 / 12
    errors = metrics.joint_position_errors(one, joints)
    assert errors[4] == pytest.approx(0.1) and np.count_nonzero(errors) == 1
    assert metrics.summary(errors) == {"mean": pytest.approx(0.01), "max": pytest.approx(0.1)}


def test_a_foot_sliding_on_the_floor_skates_at_its_speed_and_a_lifted_one_does_not_count():
    fps, speed, frames = 30.0, 0.4, 20
    feet = np.zeros((frames, 2, 3))
    feet[:, 0, 0] = speed * np.arange(frames) / fps  # right foot slides along x on the floor
    feet[:, 1, 1] = 2.0 * np.arange(frames) / fps  # left foot moves fast, but in the air
    heights = np.zeros((frames, 2))
    heights[:, 1] = 0.2
    contacts = metrics.foot_contacts(heights)
    assert contacts[:, 0].all() and not contacts[:, 1].any()
    assert metrics.foot_skating(feet, contacts, fps) == pytest.approx(speed)
    planted = feet.copy()
    planted[:, 0] = 0.0
    assert metrics.foot_skating(planted, contacts, fps) == pytest.approx(0.0)
    assert metrics.foot_skating(feet, np.zeros_like(contacts), fps) is None  # no foot on the floor: no figure
    half = contacts.copy()
    half[1::2, 0] = False  # contact every other frame only: no pair in contact at both ends
    assert metrics.foot_skating(feet, half, fps) is None


def test_penetration_is_the_depth_of_the_lowest_point_below_the_floor():
    lowest = np.array([[0.05, 0.01], [-0.003, 0.2], [0.0, -0.02]])
    np.testing.assert_allclose(metrics.ground_penetration(lowest), [0.0, 0.003, 0.02])


def test_box_lowest_point_follows_its_rotation():
    half = np.array([0.1, 0.05, 0.02])
    assert metrics.box_lowest_z(np.array([0, 0, 1.0]), np.eye(3), half) == pytest.approx(0.98)
    tilted = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], float)  # 90 degrees about x: local y points up
    assert metrics.box_lowest_z(np.array([0, 0, 1.0]), tilted, half) == pytest.approx(0.95)


def test_reprojection_error_is_zero_for_the_projection_and_counts_only_confident_keypoints():
    rotation = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], float)  # camera looking along +y, image y down
    position = np.array([0.0, -4.0, 1.0])
    intrinsics = np.array([[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]])
    points = np.random.default_rng(1).uniform(-0.5, 0.5, (5, 12, 3)) + [0, 0, 1]
    pixels = metrics.project_points(points, rotation, position, intrinsics)
    confidence = np.full((5, 12), 0.9)
    np.testing.assert_allclose(metrics.reprojection_errors(points, pixels, confidence, rotation, position, intrinsics), 0.0,
                               atol=1e-9)
    off = pixels.copy()
    off[:, 0, 0] += 12.0  # one keypoint of 12 is 12 px off: mean 1 px a frame
    np.testing.assert_allclose(metrics.reprojection_errors(points, off, confidence, rotation, position, intrinsics), 1.0)
    unsure = confidence.copy()
    unsure[:, 0] = 0.1  # that keypoint is not trusted: it does not count
    np.testing.assert_allclose(metrics.reprojection_errors(points, off, unsure, rotation, position, intrinsics), 0.0, atol=1e-9)
    # The camera looks along +y from y = -4: a point 1 m to the right of the axis at 4 m is 125 px right of centre.
    assert metrics.project_points(np.array([1.0, 0.0, 1.0]), rotation, position, intrinsics) == pytest.approx([445.0, 240.0])


def test_motion_figures_of_a_standing_humanoid_sliding_sideways(shared_humanoid):
    """The rest pose at the height where its feet touch the floor, moved 0.3 m/s along x: the
    feet are on the floor (contact), skate at 0.3 m/s and do not go through it."""
    nq, frames, fps = shared_humanoid.model.nq, 12, 30.0
    qpos = np.zeros((frames, nq))
    qpos[:, 0] = 0.3 * np.arange(frames) / fps
    qpos[:, 2] = 0.885  # tests/services/training/test_evaluate_strict.STAND_HEIGHT
    qpos[:, 3] = 1.0
    spherical = shared_humanoid.joint_qpos_adr[JOINT_IS_SPHERICAL]
    qpos[:, spherical] = 1.0  # every ball joint at rest (unit quaternion), hinges at 0
    points = body_kinematics(shared_humanoid, qpos)
    assert np.abs(points.foot_heights).max() < 0.01 and points.lowest.min() > -0.01
    figures = motion_figures(points, fps)
    assert figures["foot_skating_m_s"] == pytest.approx(0.3, rel=1e-6)
    assert figures["contact_fraction"] == 1.0 and figures["ground_penetration_m"]["max"] < 0.01
    sunk = qpos.copy()
    sunk[:, 2] -= 0.05  # 5 cm lower: the feet are 5 cm in the floor
    assert motion_figures(body_kinematics(shared_humanoid, sunk), fps)["ground_penetration_m"]["max"] == pytest.approx(
        0.05 - points.lowest.min(), abs=1e-4)  # the report rounds to 0.1 mm


def test_video_rows_map_control_steps_to_the_clip_frames():
    class Clip:
        fps, num_frames = 60.0, 100

    np.testing.assert_array_equal(video_rows(Clip, np.arange(4) / 30.0), [0, 2, 4, 6])
    assert video_rows(Clip, np.array([5.0]))[0] == 99  # past the clip's end: its last frame



def test_joints_behind_the_camera_are_not_scored_and_are_counted():
    rotation, position, intrinsics = np.eye(3), np.zeros(3), np.array([[1000.0, 0, 500], [0, 1000.0, 500], [0, 0, 1]])
    joints = np.array([[[0.0, 0.0, 3.0], [0.1, 0.0, 3.0]], [[0.0, 0.0, 3.0], [0.1, 0.0, -0.5]]])  # frame 1: one behind
    keypoints = metrics.project_points(joints, rotation, position, intrinsics) + np.array([3.0, 4.0])  # 5 px off
    confidence = np.ones((2, 2))
    errors = metrics.reprojection_errors(joints, keypoints, confidence, rotation, position, intrinsics)
    np.testing.assert_allclose(errors, [5.0, 5.0])  # the joint behind would have been 2e5 px away
    assert metrics.behind_camera(joints, rotation, position).tolist() == [False, True]
    joints[1, 0, 2] = 0.05  # both unseen: no figure for that frame
    assert np.isnan(metrics.reprojection_errors(joints, keypoints, confidence, rotation, position, intrinsics)[1])


def test_world_aligned_error_forgives_one_turn_and_shift_of_the_whole_path_but_not_the_pose():
    rng = np.random.default_rng(1)
    reference = rng.normal(size=(30, 12, 3))
    angle = 0.4
    turn = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]])
    beside = reference @ turn.T + np.array([2.0, -1.0, 0.05])  # walked beside the path, turned
    assert metrics.joint_position_errors(beside, reference).mean() > 1.0
    np.testing.assert_allclose(metrics.aligned_joint_errors(beside, reference), 0.0, atol=1e-9)
    bent = beside.copy()
    bent[:, 3] += [0.0, 0.0, 0.3]  # one joint 30 cm off in every frame stays an error
    assert metrics.aligned_joint_errors(bent, reference).mean() > 0.02
