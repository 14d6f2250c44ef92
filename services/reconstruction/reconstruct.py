"""Pose track -> ReferenceMotion: SFV's motion reconstruction (section 6).

1. The track's landmarks become the humanoid's fit points (`keypoints.py`); frames where
   the estimator read the body the wrong way round are undone (`label_flips.py`).
2. A static pinhole camera is set up (`camera.py`: focal length from the image size, up
   direction from the body) and the 3D prediction is fitted frame by frame to the humanoid
   (`initial_fit.py`): q_hat_t. Each frame's root is placed where its pose best reprojects
   onto the 2D keypoints; the ground goes under the lowest foot of most frames.
3. All frames are optimised together with Adam on
       l_rec = 10 l2D + 100 l3D + 25 lsm  (+ 100 x ground penetration)
   over the per-frame root positions, root rotations and joint exponential coordinates,
   joints clamped to their limits after every step (`losses.py`). Units, which decide how
   the paper's weights balance: l2D in per mille of the image height (confidence x L1),
   l3D in radians (root and 12 joint rotations against q_hat_t, weighted by
   w_t = exp(-delta_t), delta_t the weighted mean reprojection error of q_hat_t in the same
   image units / `delta_scale`), lsm in centimetres^2 (12 joints, adjacent frames). Every
   term is averaged over frames, so the balance does not depend on the clip's length.
   The camera itself is not optimised: with a free root trajectory, moving the camera and
   the whole motion together changes no loss term (see `camera.py`).
4. The motion is shifted so that its lowest foot point touches z = 0 and its first root
   position is above the origin, and saved with the keypoints it was made from.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from actors.character import quaternion as qn
from actors.motion.reference_motion import ReferenceMotion
from learner.errors import SfvError
from services.reconstruction.body import PoseParams, body_points
from services.reconstruction.camera import (
    PinholeCamera,
    camera_rotation_from_up,
    default_focal,
    estimate_up,
    fit_translations,
)
from services.reconstruction.config import ReconstructionConfig
from services.reconstruction.initial_fit import fit_poses_to_points
from services.reconstruction.keypoints import (
    FIT_WEIGHTS,
    JOINT_KEYPOINTS,
    NUM_JOINT_KEYPOINTS,
    ObservedPoints,
    observe,
)
from services.reconstruction.label_flips import find_label_flips, undo_label_flips
from services.reconstruction.losses import (
    ground_penetration,
    prediction_consistency,
    reprojection_error,
    reprojection_l1,
    smoothness,
)

GROUND_PERCENTILE = 10.0  # of the per-frame lowest foot point, placed on the ground before optimising


@dataclass
class Setup:
    """Everything the optimisation starts from."""

    camera: PinholeCamera
    predicted: PoseParams  # q_hat_t: the 3D prediction as humanoid poses, root at the initial position
    weights: np.ndarray  # (T, P) confidence x point weight of the 2D loss
    frame_weights: np.ndarray  # (T,) w_t = exp(-delta_t)
    px_to_unit: float  # pixels -> image units (per mille of the image height)


def check_track(track, source: str) -> None:
    frames = len(track.valid)
    if frames < 2:
        raise SfvError(f"{source}: a motion needs at least 2 frames, the pose track has {frames}")
    if not np.any(track.valid):
        raise SfvError(f"{source}: no person was found in any of the {frames} frames")
    if not (np.isfinite(track.fps) and track.fps > 0):
        raise SfvError(f"{source}: frame rate must be positive, got {track.fps}")
    for name in ("keypoints2d", "confidence", "world3d"):
        if not np.isfinite(np.asarray(getattr(track, name))).all():
            raise SfvError(f"{source}: pose track {name} holds NaN or infinite values")


def _poses(params: PoseParams, root_pos=None):
    root_pos = params.root_pos if root_pos is None else root_pos
    return body_points(root_pos, params.root_quat(), params.joint_quats())


def initialise(obs: ObservedPoints, image_size: tuple[int, int], config: ReconstructionConfig,
               dtype: torch.dtype) -> Setup:
    width, height = image_size
    focal = default_focal(image_size, config.focal_length_px)
    principal = np.array([(width - 1) / 2.0, (height - 1) / 2.0])
    up = estimate_up(obs.points3d, obs.valid, config.up_from_body, config.min_upright_consistency)
    rotation = camera_rotation_from_up(up)
    camera = PinholeCamera(rotation, np.zeros(3), focal, principal, (int(width), int(height)))

    # Camera axes -> world axes is rotation^T; for row vectors p @ rotation.
    predicted = fit_poses_to_points(obs.points3d @ rotation, config.ik_iterations, config.ik_lr, dtype)
    with torch.no_grad():
        relative, _ = _poses(predicted)
    relative = relative.double().numpy()
    weights = obs.confidence * FIT_WEIGHTS
    translations = fit_translations(relative @ rotation.T, obs.keypoints2d, weights, focal, principal)
    with torch.no_grad():
        predicted.root_pos.copy_(torch.as_tensor(translations @ rotation, dtype=dtype))
        fit, corners = _poses(predicted)
    px_to_unit = 1.0 / (height * config.image_unit)

    # w_t = exp(-delta_t): delta_t is the prediction's weighted mean reprojection error.
    projected = camera.project_torch(fit).double()
    delta = reprojection_error(projected, torch.as_tensor(obs.keypoints2d), torch.as_tensor(weights), px_to_unit).numpy()
    frame_weights = np.exp(-delta / config.delta_scale)
    seen = weights.sum(axis=1) > 0
    frame_weights[~seen] = frame_weights[seen].min() if seen.any() else 1.0

    # The ground: most frames have a foot on it, so a low percentile of the lowest foot point.
    ground = np.percentile(corners[..., 2].flatten(1).min(dim=1).values.double().numpy(), GROUND_PERCENTILE)
    with torch.no_grad():
        predicted.root_pos[:, 2] -= ground
    camera = camera.shifted(np.array([0.0, 0.0, -ground]))
    return Setup(camera, predicted, weights, frame_weights, px_to_unit)


def loss_terms(params: PoseParams, setup: Setup, observed: torch.Tensor, weights: torch.Tensor,
               predicted_rotations: torch.Tensor, frame_weights: torch.Tensor, config: ReconstructionConfig) -> dict:
    """The four terms, each averaged over frames (lsm: summed over frame pairs / T)."""
    fit, corners = _poses(params)
    frames = fit.shape[0]
    rotations = torch.cat((params.root_quat().unsqueeze(-2), params.joint_quats()), dim=-2)
    return {
        "l2d": reprojection_l1(setup.camera.project_torch(fit), observed, weights, setup.px_to_unit).mean(),
        "l3d": prediction_consistency(rotations, predicted_rotations, frame_weights).mean(),
        "lsm": smoothness(fit[:, :NUM_JOINT_KEYPOINTS], config.length_unit_m).sum() / frames,
        "ground": ground_penetration(corners, config.length_unit_m).mean(),
    }


def total_loss(terms: dict, config: ReconstructionConfig) -> torch.Tensor:
    return (config.w_2d * terms["l2d"] + config.w_3d * terms["l3d"] + config.w_smooth * terms["lsm"]
            + config.w_ground * terms["ground"])


def optimise(setup: Setup, obs: ObservedPoints, config: ReconstructionConfig, dtype: torch.dtype) -> tuple[PoseParams, dict]:
    predicted = setup.predicted
    with torch.no_grad():
        predicted_rotations = torch.cat((predicted.root_quat().unsqueeze(-2), predicted.joint_quats()), dim=-2)
    start = predicted.numpy()
    params = PoseParams.create(start["root_pos"], start["root_quat"], start["spherical"], start["revolute"], dtype)
    observed = torch.as_tensor(obs.keypoints2d, dtype=dtype)
    weights = torch.as_tensor(setup.weights, dtype=dtype)
    frame_weights = torch.as_tensor(setup.frame_weights, dtype=dtype)
    optimiser = torch.optim.Adam([
        {"params": [params.root_pos], "lr": config.lr_position},
        {"params": params.rotation_leaves(), "lr": config.lr_rotation},
    ])
    decay = torch.optim.lr_scheduler.ExponentialLR(optimiser, gamma=config.final_lr_fraction ** (1.0 / max(config.iterations, 1)))
    for _ in range(config.iterations):
        optimiser.zero_grad(set_to_none=True)
        loss = total_loss(loss_terms(params, setup, observed, weights, predicted_rotations, frame_weights, config), config)
        loss.backward()
        optimiser.step()
        decay.step()
        params.clamp_to_limits()
    with torch.no_grad():
        terms = loss_terms(params, setup, observed, weights, predicted_rotations, frame_weights, config)
    return params, {k: float(v) for k, v in terms.items()}


def reconstruct_track(track, config: ReconstructionConfig | None = None, name: str = "reconstruction") -> ReferenceMotion:
    """A humanoid ReferenceMotion from a `services.pose.PoseTrack` (see the module docstring).

    extras of the motion: keypoint_names (12,), keypoints3d (T, 12, 3) the humanoid's joints
    in the world (metres), raw_keypoints3d (T, 12, 3) BlazePose's world landmarks as
    estimated (left/right as read), turned into the world and placed at the initial root
    positions, keypoints2d (T, 12, 2) and confidence (T, 12) the 2D keypoints the fit used
    (left/right as corrected), label_flipped (T,) frames whose left/right reading was
    undone, reprojection_error_px (T,) the motion's confidence-weighted mean 2D error,
    fps, and the camera: camera_rotation (3, 3) world -> camera, camera_position (3,),
    camera_intrinsics (3, 3), image_size (2,) (width, height).
    """
    config = config or ReconstructionConfig()
    check_track(track, name)
    dtype = getattr(torch, config.dtype)
    raw = observe(track)
    flips = find_label_flips(raw, config.flip_overrule_cost) if config.fix_label_flips else np.zeros(len(raw), bool)
    obs = undo_label_flips(raw, flips)
    setup = initialise(obs, tuple(track.image_size), config, dtype)
    params, terms = optimise(setup, obs, config, dtype)
    return build_motion(name, float(track.fps), params, setup, obs, raw, flips, terms)


def build_motion(name: str, fps: float, params: PoseParams, setup: Setup, obs: ObservedPoints,
                 raw: ObservedPoints, flips: np.ndarray, terms: dict) -> ReferenceMotion:
    pose = params.numpy()
    with torch.no_grad():
        fit, corners = _poses(params)
        projected = setup.camera.project_torch(fit).double()
        error_px = reprojection_error(projected, torch.as_tensor(obs.keypoints2d), torch.as_tensor(setup.weights), 1.0).numpy()
    fit, corners = fit.double().numpy(), corners.double().numpy()
    # Lowest foot point on the ground, first root position above the origin.
    shift = np.array([-pose["root_pos"][0, 0], -pose["root_pos"][0, 1], -corners[..., 2].min()])
    camera = setup.camera.shifted(shift)
    initial_root = setup.predicted.root_pos.detach().double().numpy()
    raw_world = raw.points3d[:, :NUM_JOINT_KEYPOINTS] @ setup.camera.rotation + initial_root[:, None] + shift
    frames = len(obs)
    extras = {
        "keypoint_names": np.array(JOINT_KEYPOINTS),
        "keypoints3d": fit[:, :NUM_JOINT_KEYPOINTS] + shift,
        "raw_keypoints3d": raw_world,
        "keypoints2d": obs.keypoints2d[:, :NUM_JOINT_KEYPOINTS],
        "confidence": obs.confidence[:, :NUM_JOINT_KEYPOINTS],
        "label_flipped": flips.astype(bool),
        "reprojection_error_px": error_px,
        "fps": np.array(fps),
        "camera_rotation": camera.rotation,
        "camera_position": camera.position,
        "camera_intrinsics": camera.intrinsics,
        "image_size": np.array(camera.image_size),
        "final_losses": np.array([terms["l2d"], terms["l3d"], terms["lsm"], terms["ground"]]),
    }
    return ReferenceMotion(
        name=name,
        frame_times=np.arange(frames) / fps,
        root_pos=pose["root_pos"] + shift,
        root_rot=qn.quat_normalize(pose["root_quat"]),
        joint_rot=qn.quat_normalize(pose["joint_quats"]),
        loop=False,
        extras=extras,
    )
