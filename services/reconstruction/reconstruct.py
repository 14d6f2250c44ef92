"""Pose track -> ReferenceMotion: SFV's motion reconstruction (section 6).

1. The track's landmarks become the humanoid's fit points (`keypoints.py`); frames where
   the estimator read the body the wrong way round are undone (`label_flips.py`).
2. A static pinhole camera is set up (`camera.py`: focal length from the image size; the up
   direction from the body's axis, turned to the support-to-centre-of-mass direction where feet
   are down and levelled along a path of a metre or more: `world_rotation`) and the 3D
   prediction is fitted frame by frame to the humanoid (`initial_fit.py`): q_hat_t. Each
   frame's root is placed where its pose best reprojects onto the 2D keypoints; the ground
   goes under the lowest foot of most frames.
3. All frames are optimised together with Adam on
       l_rec = 10 l2D + 100 l3D + 25 lsm  (+ 100 x ground penetration)
             (+ 100 lcontact + 100 lslide where the foot-contact estimator says a foot is down)
             (+ w_balance lbalance: the zero-moment point over the contact feet, and a body with no
                foot down in free fall, `losses.dynamic_balance`; `balance` static: the centre of mass)
   over the per-frame root positions, root rotations and joint exponential coordinates (and,
   with contacts, the ground height: `contact_fit.py`), joints clamped to their limits after
   every step (`losses.py`). Units, which decide how
   the paper's weights balance: l2D in per mille of the image height (confidence x L1),
   l3D in radians (root and 12 joint rotations against q_hat_t, weighted by
   w_t = exp(-delta_t), delta_t the weighted mean reprojection error of q_hat_t in the same
   image units / `delta_scale`), lsm in centimetres^2 (12 joints, adjacent frames; by default
   their motion about the hips (a planted foot's ankle: its own motion) and the hips' change
   of pace, `losses.smoothness`). Every
   term is averaged over frames, so the balance does not depend on the clip's length.
   The camera itself is not optimised: with a free root trajectory, moving the camera and
   the whole motion together changes no loss term (see `camera.py`).
4. The motion is shifted so that the ground is z = 0 (without contacts: its lowest foot point
   of the clip touches it) and its first root position is above the origin; a frame whose foot
   still dips below the ground is lifted out of it. It is saved with the keypoints it was made
   from (and the contacts it was fitted to).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import torch

from actors.character import quaternion as qn
from actors.motion.reference_motion import ReferenceMotion
from learner.errors import SfvError
from services.reconstruction.body import LINK_MASS_FRACTIONS, SOLE_CORNERS, PoseParams, body_points
from services.reconstruction.camera import (
    PinholeCamera,
    balance_up,
    camera_rotation_from_up,
    default_focal,
    estimate_up,
    fit_translations,
    level_along,
    travel_direction,
)
from services.reconstruction.config import ReconstructionConfig
from services.reconstruction.contact_fit import ground_parameter, initial_ground, lift_out_of_ground
from services.reconstruction.initial_fit import fit_poses_to_points
from services.reconstruction.keypoints import (
    FIT_WEIGHTS,
    JOINT_KEYPOINTS,
    NUM_JOINT_KEYPOINTS,
    ObservedPoints,
    fit_index,
    observe,
)
from services.reconstruction.label_flips import find_label_flips, undo_label_flips
from services.reconstruction.losses import (
    contact_height,
    contact_sliding,
    ground_penetration,
    prediction_consistency,
    reprojection_error,
    reprojection_l1,
    smoothness,
    stance_tilt,
    dynamic_balance,
    static_balance,
)

CONTACT_FEET = ("right", "left")  # the order of the feet in contact arrays, as `body.FOOT_LINKS`
LOSS_NAMES = ("l2d", "l3d", "lsm", "ground", "contact", "slide", "balance", "flat")
HIP_POINTS = [fit_index("RHip"), fit_index("LHip")]  # their midpoint: the centre of the "body" smoothness
# The sole points of the feet (CONTACT_FEET order) that span the balance term's support.
HEEL_POINTS = [fit_index("RHeel"), fit_index("LHeel")]
TOE_POINTS = [fit_index("RToe"), fit_index("LToe")]
ANKLE_POINTS = [fit_index("RAnkle"), fit_index("LAnkle")]
# (track, label_flipped (T,)) -> (probabilities (T, 2), flags (T, 2) bool), feet in CONTACT_FEET
# order: `services.contacts.estimator.track_contacts` (above this package, so it is passed in).
ContactEstimate = Callable[[object, np.ndarray], tuple[np.ndarray, np.ndarray]]


@dataclass
class Setup:
    """Everything the optimisation starts from."""

    camera: PinholeCamera
    predicted: PoseParams  # q_hat_t: the 3D prediction as humanoid poses, root at the initial position
    weights: np.ndarray  # (T, P) confidence x point weight of the 2D loss
    frame_weights: np.ndarray  # (T,) w_t = exp(-delta_t)
    px_to_unit: float  # pixels -> image units (per mille of the image height)
    contacts: np.ndarray | None = None  # (T, 2) feet down (CONTACT_FEET order); None: no contact terms
    held: torch.Tensor | None = None  # (T - 1, NUM_JOINT_KEYPOINTS) the planted ankles (`held_ankles`); None without contacts
    fps: float = 30.0  # frames per second of the track (the dynamic balance term's accelerations)


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


def _poses(params: PoseParams, root_pos=None, with_com: bool = False, with_links: bool = False):
    root_pos = params.root_pos if root_pos is None else root_pos
    return body_points(root_pos, params.root_quat(), params.joint_quats(), with_com, with_links)


def _camera_path(predicted: PoseParams, rotation: np.ndarray, obs: ObservedPoints, weights: np.ndarray, focal: float,
                 principal: np.ndarray) -> np.ndarray:
    """(T, 3) camera-frame root positions that place the fitted poses on the 2D keypoints."""
    with torch.no_grad():
        relative, _ = _poses(predicted)
    return fit_translations(relative.double().numpy() @ rotation.T, obs.keypoints2d, weights, focal, principal)


def world_rotation(obs: ObservedPoints, config: ReconstructionConfig, dtype: torch.dtype, contacts: np.ndarray | None,
                   focal: float, principal: np.ndarray) -> tuple[np.ndarray, PoseParams]:
    """The world -> camera rotation and the 3D prediction's poses fitted in its world. Its up is the
    body's mean axis (`estimate_up`), turned to the support-to-centre-of-mass direction when feet
    are down (`up_from_balance`), then levelled along a root path of a metre or more (`level_travel`)."""
    up = estimate_up(obs.points3d, obs.valid, config.up_from_body, config.min_upright_consistency)
    rotation = camera_rotation_from_up(up)
    # Camera axes -> world axes is rotation^T; for row vectors p @ rotation.
    predicted = fit_poses_to_points(obs.points3d @ rotation, config.ik_iterations, config.ik_lr, dtype)
    if not config.up_from_body:
        return rotation, predicted
    turned = rotation[:, 2]
    if config.up_from_balance and contacts is not None:
        with torch.no_grad():
            _, feet, com = _poses(predicted, with_com=True)
        feet = feet.double().numpy()
        balanced = balance_up(com.double().numpy(), feet[..., SOLE_CORNERS, :].mean(axis=-2), contacts, obs.valid,
                              np.array([0.0, 0.0, 1.0]))
        if balanced is not None:
            turned = rotation @ balanced
    if config.level_travel:
        path = _camera_path(predicted, rotation, obs, obs.confidence * FIT_WEIGHTS, focal, principal)
        along = travel_direction(path, obs.valid)
        if along is not None:
            turned = level_along(turned, along)
    if turned @ rotation[:, 2] < np.cos(np.radians(0.1)):
        rotation = camera_rotation_from_up(turned)
        predicted = fit_poses_to_points(obs.points3d @ rotation, config.ik_iterations, config.ik_lr, dtype)
    return rotation, predicted


def initialise(obs: ObservedPoints, image_size: tuple[int, int], config: ReconstructionConfig,
               dtype: torch.dtype, contacts: np.ndarray | None = None, fps: float = 30.0) -> Setup:
    width, height = image_size
    focal = default_focal(image_size, config.focal_length_px)
    principal = np.array([(width - 1) / 2.0, (height - 1) / 2.0])
    weights = obs.confidence * FIT_WEIGHTS
    rotation, predicted = world_rotation(obs, config, dtype, contacts, focal, principal)
    camera = PinholeCamera(rotation, np.zeros(3), focal, principal, (int(width), int(height)))
    translations = _camera_path(predicted, rotation, obs, weights, focal, principal)
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

    ground = initial_ground(corners.double().numpy(), contacts)
    with torch.no_grad():
        predicted.root_pos[:, 2] -= ground
    camera = camera.shifted(np.array([0.0, 0.0, -ground]))
    return Setup(camera, predicted, weights, frame_weights, px_to_unit, contacts, held_ankles(contacts, dtype), float(fps))


def loss_terms(params: PoseParams, ground: torch.Tensor, setup: Setup, observed: torch.Tensor, weights: torch.Tensor,
               predicted_rotations: torch.Tensor, frame_weights: torch.Tensor, config: ReconstructionConfig) -> dict:
    """The terms of LOSS_NAMES, each averaged over frames (lsm, slide: summed over frame pairs / T);
    the contact terms are 0 without contacts, the balance term also with w_balance = 0 (then
    not computed: the other terms are exactly those without it)."""
    balance = setup.contacts is not None and config.w_balance > 0
    fit, corners, *com = _poses(params, with_com=balance, with_links=balance and config.balance == "whole_body")
    frames = fit.shape[0]
    rotations = torch.cat((params.root_quat().unsqueeze(-2), params.joint_quats()), dim=-2)
    unit = config.length_unit_m
    terms = {
        "l2d": reprojection_l1(setup.camera.project_torch(fit), observed, weights, setup.px_to_unit).mean(),
        "l3d": prediction_consistency(rotations, predicted_rotations, frame_weights).mean(),
        "lsm": smoothness(fit[:, :NUM_JOINT_KEYPOINTS], unit, config.smoothness, fit[:, HIP_POINTS].mean(dim=1),
                          setup.held).sum() / frames,
        "ground": ground_penetration(corners, unit, ground).mean(),
        "contact": torch.zeros((), dtype=fit.dtype),
        "slide": torch.zeros((), dtype=fit.dtype),
        "balance": torch.zeros((), dtype=fit.dtype),
        "flat": torch.zeros((), dtype=fit.dtype),
    }
    if setup.contacts is not None:
        contacts = torch.as_tensor(setup.contacts, dtype=fit.dtype)
        terms["contact"] = contact_height(corners, contacts, unit, ground).mean()
        terms["slide"] = contact_sliding(corners, contacts, unit).sum() / frames
        if config.w_flat > 0:
            terms["flat"] = stance_tilt(fit[:, HEEL_POINTS], fit[:, TOE_POINTS], contacts, unit).mean()
        if balance:
            terms["balance"] = balance_term(com[0], fit[:, HEEL_POINTS], fit[:, TOE_POINTS], contacts, ground, setup.fps,
                                            config, centres=com[1] if len(com) > 1 else None).mean()
    return terms


def balance_term(com: torch.Tensor, heels: torch.Tensor, toes: torch.Tensor, contacts: torch.Tensor, ground: torch.Tensor,
                 fps: float, config: ReconstructionConfig, centres: torch.Tensor | None = None) -> torch.Tensor:
    """(T,) the balance term of `config.balance`: the centre of mass (static) or the zero-moment point
    (dynamic: of the centre of mass; whole_body: of the links' centres of mass (T, 15, 3) `centres`, the
    accelerations over `balance_window_s` either side) beyond the margin from the support."""
    unit = config.length_unit_m
    if config.balance == "static":
        return static_balance(com, heels, toes, contacts, unit, config.balance_margin_m)
    half_window = max(1, int(round(config.balance_window_s * fps)))
    links = None
    if config.balance == "whole_body":
        links = (centres, torch.as_tensor(LINK_MASS_FRACTIONS, dtype=com.dtype))
    return dynamic_balance(com, heels, toes, contacts, unit, config.balance_margin_m, fps, half_window, ground[0],
                           flight=config.balance_flight, links=links)


def held_ankles(contacts: np.ndarray | None, dtype: torch.dtype) -> torch.Tensor | None:
    """(T - 1, NUM_JOINT_KEYPOINTS): 1 at the ankle of a foot down at both frames of a pair (the
    "stance" smoothness charges its own displacement there); None without contacts. Made once
    per reconstruction: the contacts do not change while it is optimised."""
    if contacts is None:
        return None
    down = torch.as_tensor(np.asarray(contacts, bool), dtype=dtype)
    both = down[1:] * down[:-1]  # (T - 1, 2), CONTACT_FEET order
    held = torch.zeros((len(down) - 1, NUM_JOINT_KEYPOINTS), dtype=dtype)
    held[:, ANKLE_POINTS] = both
    return held


def total_loss(terms: dict, config: ReconstructionConfig) -> torch.Tensor:
    return (config.w_2d * terms["l2d"] + config.w_3d * terms["l3d"] + config.w_smooth * terms["lsm"]
            + config.w_ground * terms["ground"] + config.w_contact * terms["contact"] + config.w_slide * terms["slide"]
            + config.w_balance * terms["balance"] + config.w_flat * terms["flat"])


def optimise(setup: Setup, obs: ObservedPoints, config: ReconstructionConfig,
             dtype: torch.dtype) -> tuple[PoseParams, float, dict]:
    """The optimised poses, the ground height they stand on (0 without contacts) and the final terms."""
    predicted = setup.predicted
    with torch.no_grad():
        predicted_rotations = torch.cat((predicted.root_quat().unsqueeze(-2), predicted.joint_quats()), dim=-2)
    start = predicted.numpy()
    params = PoseParams.create(start["root_pos"], start["root_quat"], start["spherical"], start["revolute"], dtype)
    observed = torch.as_tensor(obs.keypoints2d, dtype=dtype)
    weights = torch.as_tensor(setup.weights, dtype=dtype)
    frame_weights = torch.as_tensor(setup.frame_weights, dtype=dtype)
    ground = ground_parameter(setup.contacts is not None, dtype)
    optimiser = torch.optim.Adam([
        {"params": [params.root_pos] + ([ground] if ground.requires_grad else []), "lr": config.lr_position},
        {"params": params.rotation_leaves(), "lr": config.lr_rotation},
    ])
    decay = torch.optim.lr_scheduler.ExponentialLR(optimiser, gamma=config.final_lr_fraction ** (1.0 / max(config.iterations, 1)))
    for _ in range(config.iterations):
        optimiser.zero_grad(set_to_none=True)
        loss = total_loss(loss_terms(params, ground, setup, observed, weights, predicted_rotations, frame_weights, config),
                          config)
        loss.backward()
        optimiser.step()
        decay.step()
        params.clamp_to_limits()
    with torch.no_grad():
        terms = loss_terms(params, ground, setup, observed, weights, predicted_rotations, frame_weights, config)
    return params, float(ground.detach()[0]), {k: float(v) for k, v in terms.items()}


def reconstruct_track(track, config: ReconstructionConfig | None = None, name: str = "reconstruction",
                      contact_estimate: ContactEstimate | None = None) -> ReferenceMotion:
    """A humanoid ReferenceMotion from a `services.pose.PoseTrack` (see the module docstring);
    `contact_estimate` (None: no contacts) gives the feet that are down, which the contact terms
    put on the ground (`config.w_contact` > 0) and the motion records.

    extras of the motion: keypoint_names (12,), keypoints3d (T, 12, 3) the humanoid's joints
    in the world (metres), raw_keypoints3d (T, 12, 3) BlazePose's world landmarks as
    estimated (left/right as read), turned into the world and placed at the initial root
    positions, keypoints2d (T, 12, 2) and confidence (T, 12) the 2D keypoints the fit used
    (left/right as corrected), label_flipped (T,) frames whose left/right reading was
    undone, reprojection_error_px (T,) the motion's confidence-weighted mean 2D error,
    fps, the camera: camera_rotation (3, 3) world -> camera, camera_position (3,),
    camera_intrinsics (3, 3), image_size (2,) (width, height), final_losses with their
    final_loss_names; with a contact estimate also contact_probability (T, 2), contacts (T, 2)
    bool and contact_feet (2,).
    """
    config = config or ReconstructionConfig()
    check_track(track, name)
    dtype = getattr(torch, config.dtype)
    raw = observe(track)
    flips = find_label_flips(raw, config.flip_overrule_cost) if config.fix_label_flips else np.zeros(len(raw), bool)
    obs = undo_label_flips(raw, flips)
    contact_extras, fitted = {}, None
    if contact_estimate is not None:
        probabilities, flags = contact_estimate(track, flips)
        contact_extras = {"contact_probability": np.asarray(probabilities), "contacts": np.asarray(flags, bool),
                          "contact_feet": np.array(CONTACT_FEET)}
        fitted = contact_extras["contacts"] if config.w_contact > 0 and contact_extras["contacts"].any() else None
    setup = initialise(obs, tuple(track.image_size), config, dtype, fitted, float(track.fps))
    params, ground, terms = optimise(setup, obs, config, dtype)
    motion = build_motion(name, float(track.fps), params, ground, setup, obs, raw, flips, terms)
    motion.extras.update(contact_extras)
    return motion


def placement(root_pos: np.ndarray, corners: np.ndarray, ground: float, fitted_ground: bool) -> tuple[np.ndarray, np.ndarray]:
    """The shift (3,) that puts the ground at z = 0 (without a fitted ground: the clip's lowest
    foot point) and the first root above the origin, and each frame's lift (T,) out of the ground."""
    floor = ground if fitted_ground else corners[..., 2].min()
    shift = np.array([-root_pos[0, 0], -root_pos[0, 1], -floor])
    return shift, lift_out_of_ground(corners + shift)


def build_motion(name: str, fps: float, params: PoseParams, ground: float, setup: Setup, obs: ObservedPoints,
                 raw: ObservedPoints, flips: np.ndarray, terms: dict) -> ReferenceMotion:
    pose = params.numpy()
    with torch.no_grad():
        fit, corners = _poses(params)
    fit, corners = fit.double().numpy(), corners.double().numpy()
    shift, lift = placement(pose["root_pos"], corners, ground, setup.contacts is not None)
    lifted = np.zeros((len(lift), 3))
    lifted[:, 2] = lift
    fit = fit + shift + lifted[:, None]
    camera = setup.camera.shifted(shift)
    error_px = reprojection_error(camera.project_torch(torch.as_tensor(fit)), torch.as_tensor(obs.keypoints2d),
                                  torch.as_tensor(setup.weights), 1.0).numpy()
    initial_root = setup.predicted.root_pos.detach().double().numpy()
    raw_world = raw.points3d[:, :NUM_JOINT_KEYPOINTS] @ setup.camera.rotation + initial_root[:, None] + shift
    frames = len(obs)
    extras = {
        "keypoint_names": np.array(JOINT_KEYPOINTS),
        "keypoints3d": fit[:, :NUM_JOINT_KEYPOINTS],
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
        "final_losses": np.array([terms[k] for k in LOSS_NAMES]),
        "final_loss_names": np.array(LOSS_NAMES),
    }
    return ReferenceMotion(
        name=name,
        frame_times=np.arange(frames) / fps,
        root_pos=pose["root_pos"] + shift + lifted,
        root_rot=qn.quat_normalize(pose["root_quat"]),
        joint_rot=qn.quat_normalize(pose["joint_quats"]),
        loop=False,
        extras=extras,
    )
