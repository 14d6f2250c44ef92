"""Unit tests of the reconstruction's pieces: kinematics, loss terms, camera, keypoint mapping,
initial fit, label flips, metrics."""
import dataclasses

import numpy as np
import pytest
import torch

from actors.character import quaternion as qn
from services.reconstruction.batched_kinematics import link_frames, quat_to_matrix
from services.reconstruction.body import REVOLUTE_LIMITS, SPHERICAL_LIMITS, PoseParams, body_points
from services.reconstruction.camera import (
    PinholeCamera,
    camera_rotation_from_up,
    estimate_up,
    fit_translations,
)
from services.reconstruction.initial_fit import fit_poses_to_points
from services.reconstruction.keypoints import JOINT_KEYPOINTS, NUM_FIT, NUM_JOINT_KEYPOINTS, fit_index, observe
from services.reconstruction.kinematics_torch import forward_kinematics_torch, joint_quats_from_params_torch
from services.reconstruction.label_flips import find_label_flips, mirrored_reading, undo_label_flips
from services.reconstruction.losses import (
    contact_height,
    contact_sliding,
    ground_penetration,
    prediction_consistency,
    reprojection_error,
    reprojection_l1,
    rotation_distance,
    smoothness,
)
from services.reconstruction.metrics import acceleration_error, mpjpe, pa_mpjpe
from services.reconstruction.synthetic import make_clip


def random_params(frames: int, seed: int = 0) -> PoseParams:
    rng = np.random.default_rng(seed)
    spherical = rng.uniform(SPHERICAL_LIMITS[..., 0], SPHERICAL_LIMITS[..., 1], (frames,) + SPHERICAL_LIMITS.shape[:-1])
    revolute = rng.uniform(REVOLUTE_LIMITS[:, 0], REVOLUTE_LIMITS[:, 1], (frames, len(REVOLUTE_LIMITS)))
    root_quat = qn.quat_normalize(rng.normal(size=(frames, 4)))
    root_pos = rng.normal(size=(frames, 3)) + np.array([0.0, 4.0, 1.0])
    return PoseParams.create(root_pos, root_quat, spherical, revolute)


def camera() -> PinholeCamera:
    return PinholeCamera(camera_rotation_from_up(np.array([0.0, -1.0, 0.0])), np.array([0.0, -2.0, 1.0]), 800.0,
                         np.array([319.5, 239.5]), (640, 480))


def test_batched_kinematics_equal_the_reference_kinematics():
    params = random_params(7)
    with torch.no_grad():
        quats = params.joint_quats()
        reference_quats = joint_quats_from_params_torch(params.spherical, params.revolute)
        pos, rot = forward_kinematics_torch(params.root_pos, params.root_quat(), reference_quats)
        batched_pos, batched_rot = link_frames(params.root_pos, params.root_quat(), quats)
    assert torch.allclose(quats, reference_quats, atol=1e-12)
    assert torch.allclose(batched_pos, pos, atol=1e-10)
    assert torch.allclose(batched_rot, quat_to_matrix(rot), atol=1e-10)


def test_l2d_is_zero_on_the_projections_and_counts_pixels_otherwise():
    params, cam = random_params(5, seed=1), camera()
    with torch.no_grad():
        fit, _ = body_points(params.root_pos, params.root_quat(), params.joint_quats())
        projected = cam.project_torch(fit)
    weight = torch.rand(5, NUM_FIT, dtype=torch.float64)
    assert reprojection_l1(projected, projected.clone(), weight, 0.5).abs().max() < 1e-9
    shifted = projected + torch.tensor([3.0, -1.0], dtype=torch.float64)  # 4 px of L1 per point
    expected = weight.sum(-1) * 4.0 * 0.5
    assert torch.allclose(reprojection_l1(projected, shifted, weight, 0.5), expected)
    assert torch.allclose(reprojection_error(projected, shifted, weight, 1.0), torch.full((5,), np.sqrt(10.0), dtype=torch.float64))


def test_l3d_is_zero_when_equal_and_measures_the_difference_angle():
    params = random_params(4, seed=2)
    with torch.no_grad():
        rotations = torch.cat((params.root_quat().unsqueeze(-2), params.joint_quats()), dim=-2)
    frame_weights = torch.tensor([1.0, 0.5, 0.25, 0.0], dtype=torch.float64)
    assert prediction_consistency(rotations, rotations.clone(), frame_weights).abs().max() < 1e-3  # eps of the angle's sqrt
    turn = torch.as_tensor(qn.quat_from_axis_angle(np.array([0.0, 0.3, 0.0])))
    turned = rotations.clone()
    turned[:, 5] = torch.as_tensor(qn.quat_mul(rotations[:, 5].numpy(), turn.numpy()))
    loss = prediction_consistency(turned, rotations, frame_weights)
    assert torch.allclose(loss, 0.3 * frame_weights, atol=2e-3)
    assert torch.allclose(rotation_distance(rotations, -rotations), torch.zeros(4, 13, dtype=torch.float64), atol=1e-3)


def test_lsm_is_zero_for_a_constant_pose_and_squares_displacements():
    params = random_params(1, seed=3)
    with torch.no_grad():
        fit, _ = body_points(params.root_pos, params.root_quat(), params.joint_quats())
    still = fit.expand(6, -1, -1)[:, :NUM_JOINT_KEYPOINTS]
    assert smoothness(still, 0.01).abs().max() == 0.0
    moving = still + torch.arange(6, dtype=torch.float64)[:, None, None] * torch.tensor([0.02, 0.0, 0.0], dtype=torch.float64)
    # 2 cm per frame = 2 units per joint per frame pair, squared, over 12 joints.
    assert torch.allclose(smoothness(moving, 0.01), torch.full((5,), 4.0 * NUM_JOINT_KEYPOINTS, dtype=torch.float64))


def _still_joints() -> torch.Tensor:
    """(6, J, 3) one random pose's joints held for six frames."""
    params = random_params(1, seed=3)
    with torch.no_grad():
        fit, _ = body_points(params.root_pos, params.root_quat(), params.joint_quats())
    return fit.expand(6, -1, -1)[:, :NUM_JOINT_KEYPOINTS]


def _travelling(still: torch.Tensor) -> torch.Tensor:
    """The same pose carried 10 cm along x each frame."""
    return still + torch.arange(6, dtype=torch.float64)[:, None, None] * torch.tensor([0.1, 0.0, 0.0], dtype=torch.float64)


def hips(points: torch.Tensor) -> torch.Tensor:
    return points[:, [JOINT_KEYPOINTS.index("RHip"), JOINT_KEYPOINTS.index("LHip")]].mean(dim=1)


def test_the_body_smoothness_leaves_a_steady_travel_free_and_charges_the_body_and_changes_of_pace():
    """A run across the view: SFV's l_sm charges the travel itself, "body" and "acceleration" do not."""
    still = _still_joints()
    steady = _travelling(still)
    assert smoothness(steady, 0.01, "displacement").min() > 0.0
    assert smoothness(steady, 0.01, "body", hips(steady)).abs().max() < 1e-9
    assert smoothness(steady, 0.01, "acceleration").abs().max() < 1e-9
    # An arm that swings while the body travels costs "body" what it costs SFV's term standing still.
    swing = steady.clone()
    wrist = JOINT_KEYPOINTS.index("RWrist")
    swing[:, wrist, 2] += 0.05 * torch.tensor([0.0, 1.0, 0.0, 1.0, 0.0, 1.0], dtype=torch.float64)
    standing_swing = still.clone()
    standing_swing[:, wrist, 2] = swing[:, wrist, 2] - (steady - still)[:, wrist, 2]
    assert torch.allclose(smoothness(swing, 0.01, "body", hips(swing)), smoothness(standing_swing, 0.01)[1:])
    # A change of pace costs J times the hips' squared change of displacement.
    slowing = still.clone()
    slowing[3:] += torch.tensor([0.03, 0.0, 0.0], dtype=torch.float64)  # one 3 cm step in six frames
    lsm = smoothness(slowing, 0.01, "body", hips(slowing))
    assert torch.allclose(lsm[1:3], torch.full((2,), 9.0 * NUM_JOINT_KEYPOINTS, dtype=torch.float64))
    with pytest.raises(ValueError, match="smoothness mode"):
        smoothness(still, 0.01, "speed")


def test_the_stance_smoothness_leaves_a_planted_leg_to_the_slide_term():
    """A body travelling over a planted foot: "body" charges the foot's motion about the hips at
    the body's speed; "stance" charges a held joint for its own motion, and the rest as "body"."""
    still = _still_joints()
    travel = _travelling(still)
    ankle = JOINT_KEYPOINTS.index("RAnkle")
    travel[:, ankle] = still[:, ankle]  # the right ankle stays put while the body passes over it
    held = torch.zeros((5, NUM_JOINT_KEYPOINTS), dtype=torch.float64)
    held[:, ankle] = 1.0
    body = smoothness(travel, 0.01, "body", hips(travel))
    assert torch.allclose(body, torch.full((4,), 100.0, dtype=torch.float64))  # 10 cm per frame about the hips, squared
    assert smoothness(travel, 0.01, "stance", hips(travel), held).abs().max() < 1e-9
    assert torch.allclose(smoothness(travel, 0.01, "stance", hips(travel)), body)  # nothing held: "body"
    dragged = _travelling(still)
    assert smoothness(dragged, 0.01, "body", hips(dragged)).abs().max() < 1e-9  # an ankle dragged along is free for "body"
    assert torch.allclose(smoothness(dragged, 0.01, "stance", hips(dragged), held), torch.full((4,), 100.0, dtype=torch.float64))


def test_ground_penalty_counts_only_points_below_the_ground():
    corners = torch.tensor([[[0.0, 0.0, 0.1], [0.0, 0.0, -0.02]], [[0.0, 0.0, 0.0], [1.0, 1.0, 0.5]]], dtype=torch.float64)
    assert torch.allclose(ground_penetration(corners, 0.01), torch.tensor([4.0, 0.0], dtype=torch.float64))


def test_contact_height_counts_the_lowest_corner_of_feet_in_contact_either_side_of_the_ground():
    corners = torch.zeros((2, 2, 8, 3), dtype=torch.float64)
    corners[..., 2] = 0.2
    corners[0, 0, 5, 2] = 0.03  # right foot's lowest corner 3 cm up
    corners[1, 1, 2, 2] = -0.01  # left foot 1 cm down
    contacts = torch.tensor([[1.0, 0.0], [1.0, 1.0]], dtype=torch.float64)
    assert torch.allclose(contact_height(corners, contacts, 0.01), torch.tensor([9.0, 400.0 + 1.0], dtype=torch.float64))
    # against a ground 20 cm up: the right foot is 17 cm below it, the left 21 cm
    assert torch.allclose(contact_height(corners, contacts, 0.01, ground=0.2), torch.tensor([289.0, 441.0],
                                                                                           dtype=torch.float64))


def test_contact_sliding_counts_steps_of_feet_down_at_both_ends_robustly():
    corners = torch.zeros((3, 2, 8, 3), dtype=torch.float64)
    corners[1, 0, :, 0] = 0.03  # the right foot steps 3 cm, then 4 cm back and up
    corners[2, 0, :, 0] = -0.01
    corners[2, 1, :, 1] = 0.5  # the left foot jumps, but it is in the air at frame 2
    contacts = torch.tensor([[1.0, 1.0], [1.0, 1.0], [1.0, 0.0]], dtype=torch.float64)
    slide = contact_sliding(corners, contacts, 0.01, smooth=0.1)
    expected = torch.tensor([np.hypot(3.0, 0.1) - 0.1, np.hypot(4.0, 0.1) - 0.1], dtype=torch.float64)
    assert torch.allclose(slide, expected)
    # about linear for a long step (a squared term would grow 100 times): a foot called down while
    # it swings does not dominate the loss
    assert float(contact_sliding(corners * 10, contacts, 0.01)[1]) < 11.0 * float(slide[1])


def test_joint_clamp_puts_every_parameter_inside_its_limits():
    params = random_params(3, seed=4)
    with torch.no_grad():
        params.spherical.mul_(5.0)
        params.revolute.mul_(5.0)
    params.clamp_to_limits()
    assert (params.spherical >= torch.as_tensor(SPHERICAL_LIMITS[..., 0]) - 1e-12).all()
    assert (params.spherical <= torch.as_tensor(SPHERICAL_LIMITS[..., 1]) + 1e-12).all()
    assert (params.revolute >= torch.as_tensor(REVOLUTE_LIMITS[:, 0]) - 1e-12).all()
    assert (params.revolute <= torch.as_tensor(REVOLUTE_LIMITS[:, 1]) + 1e-12).all()


def test_camera_rotation_maps_up_and_keeps_the_image_x_axis_in_the_world_xz_plane():
    up_cam = np.array([0.2, -0.9, -0.35])
    up_cam /= np.linalg.norm(up_cam)
    rotation = camera_rotation_from_up(up_cam)
    assert np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)
    assert np.isclose(np.linalg.det(rotation), 1.0)
    assert np.allclose(rotation @ np.array([0.0, 0.0, 1.0]), up_cam)
    assert abs(rotation[0, 1]) < 1e-12  # the image's x axis has no world-y component
    assert rotation[0, 0] > 0.9 and rotation[2, 1] > 0.9  # image right ~ world x, optical axis ~ world y


def test_up_from_an_upright_body_and_level_fallback():
    clip = make_clip(frames=10, depth_noise_m=0.0)
    obs = observe(clip.track)
    true_up = clip.camera.rotation @ np.array([0.0, 0.0, 1.0])
    up = estimate_up(obs.points3d, obs.valid, use_body=True, min_consistency=0.8)
    assert np.degrees(np.arccos(up @ true_up)) < 15.0  # the body's lean, not the camera's tilt (10 degrees here)
    assert np.allclose(estimate_up(obs.points3d, obs.valid, use_body=False, min_consistency=0.8), [0.0, -1.0, 0.0])
    upside_down = obs.points3d * np.array([1.0, -1.0, 1.0])
    assert np.allclose(estimate_up(upside_down, obs.valid, use_body=True, min_consistency=0.8), [0.0, -1.0, 0.0])


def test_fit_translations_recovers_the_camera_frame_position():
    params, cam = random_params(4, seed=5), camera()
    with torch.no_grad():
        fit, _ = body_points(params.root_pos, params.root_quat(), params.joint_quats())
    fit = fit.numpy()
    root_cam = cam.to_camera(params.root_pos.detach().numpy())
    offsets_cam = (fit - params.root_pos.detach().numpy()[:, None]) @ cam.rotation.T
    found = fit_translations(offsets_cam, cam.project(fit), np.ones((4, NUM_FIT)), cam.focal, cam.principal)
    assert np.allclose(found, root_cam, atol=1e-6)


def test_fit_translations_interpolates_frames_without_confident_points():
    """A walker crossing the image: an unseen frame near the start lies between its neighbours,
    not at the clip's median position (the middle of the walk)."""
    frames = 20
    params, cam = random_params(frames, seed=6), camera()
    with torch.no_grad():
        params.root_pos[:, 0] = torch.linspace(-2.0, 2.0, frames, dtype=params.root_pos.dtype)
        fit, _ = body_points(params.root_pos, params.root_quat(), params.joint_quats())
    fit = fit.numpy()
    root_cam = cam.to_camera(params.root_pos.detach().numpy())
    offsets_cam = (fit - params.root_pos.detach().numpy()[:, None]) @ cam.rotation.T
    confidence = np.ones((frames, NUM_FIT))
    confidence[[0, 2, 3]] = 0.0  # unseen: the first frame and two near the start
    found = fit_translations(offsets_cam, cam.project(fit), confidence, cam.focal, cam.principal)
    assert np.allclose(found[1], root_cam[1], atol=1e-6) and np.allclose(found[4:], root_cam[4:], atol=1e-6)
    assert np.allclose(found[0], found[1])  # held at the clip's start
    assert np.allclose(found[2], found[1] + (found[4] - found[1]) / 3, atol=1e-9)
    assert np.allclose(found[3], found[1] + 2 * (found[4] - found[1]) / 3, atol=1e-9)


def test_label_flips_found_by_temporal_coherence_and_undone():
    clip = make_clip(frames=30, pixel_noise=1.0, depth_noise_m=0.01, seed=3)
    obs = observe(clip.track)
    assert not find_label_flips(obs).any()
    misread = np.zeros(30, bool)
    misread[12:19] = True
    corrupted = undo_label_flips(obs, misread)  # the estimator's mirrored reading on frames 12..18
    assert np.array_equal(find_label_flips(corrupted), misread)
    repaired = undo_label_flips(corrupted, misread)
    assert np.allclose(repaired.points3d, obs.points3d) and np.allclose(repaired.keypoints2d, obs.keypoints2d)
    assert np.allclose(mirrored_reading(mirrored_reading(obs)).points3d, obs.points3d)


def test_metrics_ignore_similarity_and_see_jitter():
    rng = np.random.default_rng(0)
    truth = rng.normal(size=(20, 12, 3))
    rotation = camera_rotation_from_up(np.array([0.3, -0.8, 0.2]) / np.linalg.norm([0.3, -0.8, 0.2]))
    moved = 1.7 * truth @ rotation.T + np.array([1.0, -2.0, 0.5])
    assert mpjpe(moved, truth) < 1e-9 and pa_mpjpe(moved, truth) < 1e-9 and acceleration_error(moved, truth) < 1e-9
    jitter = truth + rng.normal(0.0, 0.01, truth.shape)
    assert acceleration_error(jitter, truth) > 0.02  # second differences of 1 cm noise: about 2.4 cm
    assert 0.005 < pa_mpjpe(jitter, truth) < 0.02


def test_observe_maps_blazepose_landmarks_onto_the_fit_points():
    clip = make_clip(frames=3)
    names = list(clip.track.keypoint_names)
    rng = np.random.default_rng(1)
    track = dataclasses.replace(clip.track, keypoints2d=rng.normal(size=clip.track.keypoints2d.shape),
                                confidence=rng.uniform(size=clip.track.confidence.shape))
    obs = observe(track)
    right_hip, left_ear, right_ear = names.index("right_hip"), names.index("left_ear"), names.index("right_ear")
    assert np.allclose(obs.keypoints2d[:, fit_index("RHip")], track.keypoints2d[:, right_hip])
    assert np.allclose(obs.keypoints2d[:, fit_index("Head")], track.keypoints2d[:, [left_ear, right_ear]].mean(axis=1))
    assert np.allclose(obs.confidence[:, fit_index("Head")], track.confidence[:, [left_ear, right_ear]].min(axis=1))
    assert np.allclose(obs.keypoints2d[:, fit_index("LToe")], track.keypoints2d[:, names.index("left_foot_index")])


def test_initial_fit_recovers_the_pose_of_exact_landmarks():
    clip = make_clip(frames=8, pixel_noise=0.0, depth_noise_m=0.0)
    obs = observe(clip.track)
    points_world = obs.points3d @ clip.camera.rotation  # camera axes -> world axes
    params = fit_poses_to_points(points_world, iterations=200, lr=0.05)
    with torch.no_grad():
        fit, _ = body_points(params.root_pos, params.root_quat(), params.joint_quats())
    fitted = fit.numpy() - fit.numpy()[:, [fit_index("RHip"), fit_index("LHip")]].mean(axis=1, keepdims=True)
    truth = points_world - points_world[:, [fit_index("RHip"), fit_index("LHip")]].mean(axis=1, keepdims=True)
    # The humanoid has the synthetic person's proportions, so directions fix positions too.
    assert np.abs(fitted - truth)[:, :NUM_JOINT_KEYPOINTS].max() < 0.02
