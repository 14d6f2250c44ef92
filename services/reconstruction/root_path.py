"""The root path of a root-free motion from its foot contacts: contact-anchored odometry.

A moving camera hides the person's travel, so the reconstruction drops the horizontal root path
(`root_free.py`). The body still tells it: a foot that is down stays put in the world, so from
one frame to the next the root moves by the change of the foot-to-root vector of the
root-relative 3D pose (WHAM refines its root path the same way). Per frame step:

- a foot's anchor is its lowest sole point (a soft minimum over the foot box's corners, a fixed
  point of the foot between the two frames): the foot rolls from heel to toe, and anchoring the
  foot box's centre instead let the walk's path drift (see `ANCHOR_SOFTNESS_M`);
- each foot down at both frames proposes a root step, weighted by its contact confidence (the
  smaller of the two frames'); when both are down but disagree by more than `DISAGREE_MPS`
  (one of them is a swinging foot labelled down), the one nearer the previous step wins;
- steps with no foot down (flight) are bridged by a ballistic arc joining take-off and landing:
  horizontally the mean of the take-off and landing velocities, vertically the parabola under
  gravity through the take-off and landing heights;
- height: while a foot is down its anchor is on the floor (z = 0), so the root stands at minus
  the anchor's root-relative height.

Camera seam: `frame_yaw` (T,) turns each frame's root-relative pose into the world of frame 0.
In principle a reconstruction fitted with a static camera turns with a panning one (a camera
that panned by a shows the world turned by a); `camera_yaw` reads the pan from the track's
camera path (`services/pose/camera_path.py`; stored as camera_pan_px / camera_zoom) and the
motion's intrinsics. Measured, the fit keeps the steps in the image plane instead, so the stored
path does not use it (`TURN_BY_PAN`). Tilt and the camera's own travel are not used.

Confidence per frame: the contact confidence where a foot is down; inside a gap
`FLIGHT_CONFIDENCE` of the smaller edge confidence, scaled down where the gap is longer than a
flight (`MAX_FLIGHT_S`: then the contacts are missing, not the ground); 0 before the first and
after the last contact (the path is held there).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from actors.character import quaternion as qn
from actors.character.foot_contact import FOOT_LINKS, SOLE_CORNERS
from actors.character.kinematics import forward_kinematics
from services.reconstruction.plausibility import flag_runs

GRAVITY = 9.81
DOWN = 0.5  # a foot with contact confidence >= DOWN counts as down
# Soft minimum over the sole corners' heights. On the looped DeepMimic walk (10 s at 30 fps,
# contacts from foot height) the foot box's centre as anchor left a start-aligned RTE of 1.9 %,
# the soft sole point 0.08 % (the run: 8.9 % and 6.7 %; bench/results/root_path_estimate.json).
ANCHOR_SOFTNESS_M = 0.01
# Two feet down whose steps differ by more than this speed: one of them swings. Labelled double
# support agrees to 0.17 m/s (median) on the walk, 0.36 on dance_a; without the rule the walk's
# start-aligned RTE is 0.41 % instead of 0.08 %, with 10 % of the contacts flipped 1.03 % instead
# of 0.20 % (with 3 cm labels 1 m/s scored within 0.15 % RTE of 0.5 on every clip, 2 m/s lost
# 0.6 % on dance_a).
DISAGREE_MPS = 0.5
# The longest gaps between contacts in the DeepMimic clips at 30 fps: the run's 0.13 s, the
# jump's 0.43 s, the spin's 0.63 s; a longer gap is missing contacts, and a parabola over a 1 s
# gap would rise 1.2 m.
MAX_FLIGHT_S = 0.7
FLIGHT_CONFIDENCE = 0.5
# Steps averaged for the take-off and the landing velocity; the flight goes at their mean. The
# take-off side alone (what physics says of a true flight) did better on the run (3.4 against
# 3.9 % RTE) but worse where a gap is missing contacts (the spin: 8.8 against 5.0 %; 3 cm labels).
EDGE_STEPS = 4
# Contact flags are median-filtered over this many frames before use: with 10 % of the frames
# flipped the walk's start-aligned RTE was 0.94 % unfiltered and 0.20 % over 3 frames (5 frames:
# 0.19 %, but that closes a 2-frame flight).
MEDIAN_FRAMES = 3
# The reconstruction's pose is not turned back by the camera's pan unless asked: on synthetic
# video of a camera 5 m away panning to follow the walk (36 degrees) the static-camera fit kept the
# feet's steps in the image plane, and turning them back raised the RTE from 2.0 to 2.5 % and the
# heading error from 3.5 to 6.1 degrees; on the run (62 degrees) RTE 16.0 against 15.8 %
# (bench/results/root_path_moving_camera.json).
TURN_BY_PAN = False


@dataclass(frozen=True)
class RootPath:
    position: np.ndarray  # (T, 3) estimated root positions (Z up, floor at z = 0)
    confidence: np.ndarray  # (T,) in [0, 1]


def sole_points(root_rot: np.ndarray, joint_rot: np.ndarray) -> np.ndarray:
    """(T, 2, 8, 3) the foot boxes' corners (right, left) relative to the root, in world axes."""
    pos, rot = forward_kinematics(np.zeros(root_rot.shape[:-1] + (3,)), root_rot, joint_rot)
    feet = []
    for link, corners in zip(FOOT_LINKS, SOLE_CORNERS):
        link_rot = np.broadcast_to(rot[:, link, None, :], rot.shape[:1] + corners.shape[:1] + (4,))
        feet.append(pos[:, link, None, :] + qn.quat_rotate(link_rot, np.broadcast_to(corners, link_rot.shape[:-1] + (3,))))
    return np.stack(feet, axis=1)


def camera_yaw(pan_px: np.ndarray, zoom: np.ndarray, focal_px: float) -> np.ndarray:
    """(T,) yaw (rad, about +z) that turns each frame's reconstructed pose into frame 0's world:
    the view turned right (+pan) by atan(pan / focal) per frame, the focal growing with the zoom."""
    focal = focal_px * np.cumprod(np.where(np.isfinite(zoom), zoom, 1.0))
    turn = np.arctan2(np.nan_to_num(np.asarray(pan_px, np.float64)), focal)
    return -np.cumsum(turn)


def smooth_contacts(contact: np.ndarray, frames: int | None = None) -> np.ndarray:
    """(T, 2) contact confidences median-filtered over `frames` (odd; default `MEDIAN_FRAMES`)
    frames, ends repeated."""
    frames = MEDIAN_FRAMES if frames is None else frames
    half = frames // 2
    padded = np.concatenate([contact[:1]] * half + [contact] + [contact[-1:]] * half)
    windows = np.stack([padded[i:i + len(contact)] for i in range(frames)])
    return np.median(windows, axis=0)


def _anchor_weights(points: np.ndarray) -> np.ndarray:
    heights = points[..., 2]
    w = np.exp(-(heights - heights.min(axis=-1, keepdims=True)) / ANCHOR_SOFTNESS_M)
    return w / w.sum(axis=-1, keepdims=True)


def _foot_steps(points: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """(T-1, 2, 2) the horizontal root step each foot proposes, its anchor held still."""
    anchor_now = (weights[:-1, ..., None] * points[:-1]).sum(axis=-2)
    anchor_next = (weights[:-1, ..., None] * points[1:]).sum(axis=-2)
    return (anchor_now - anchor_next)[..., :2]


def _stance_steps(steps: np.ndarray, weights: np.ndarray, dt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Combined (T-1, 2) steps and (T-1,) whether a foot carried them (NaN steps elsewhere)."""
    combined, stance = np.full(steps.shape[::2], np.nan), np.zeros(len(steps), bool)
    previous = None
    for t in range(len(steps)):
        w = weights[t].copy()
        both = (w >= DOWN).all()
        if both and previous is not None and np.linalg.norm(steps[t, 0] - steps[t, 1]) > DISAGREE_MPS * dt[t]:
            w[np.argmax(np.linalg.norm(steps[t] - previous * dt[t], axis=-1))] = 0.0
        w = np.where(w >= DOWN, w, 0.0)
        if w.sum() > 0:
            combined[t] = (w[:, None] * steps[t]).sum(axis=0) / w.sum()
            stance[t], previous = True, combined[t] / dt[t]
    return combined, stance


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) of each run of True (`plausibility.flag_runs`' runs, the end exclusive)."""
    return [(first, last + 1) for first, last in flag_runs(mask)]


def _bridge_steps(steps: np.ndarray, stance: np.ndarray, dt: np.ndarray) -> np.ndarray:
    """Flight steps at the mean of the take-off and landing velocities (one side at the ends)."""
    velocity = steps / dt[:, None]
    bridged = steps.copy()
    for start, end in _runs(~stance):
        before = velocity[max(start - EDGE_STEPS, 0):start][stance[max(start - EDGE_STEPS, 0):start]]
        after = velocity[end:end + EDGE_STEPS][stance[end:end + EDGE_STEPS]]
        edges = [v.mean(axis=0) for v in (before, after) if len(v)]
        v = np.mean(edges, axis=0) if edges else np.zeros(2)
        bridged[start:end] = v * dt[start:end, None]
    return bridged


def _heights(points: np.ndarray, weights: np.ndarray, contact: np.ndarray, times: np.ndarray) -> np.ndarray:
    """(T,) root heights: the anchor on the floor where a foot is down, a parabola across a
    flight, a straight line across a longer gap, held before the first and after the last contact."""
    anchor_z = (weights * points[..., 2]).sum(axis=-1)  # (T, 2)
    down = np.where(contact >= DOWN, contact, 0.0)
    stance = down.sum(axis=1) > 0
    if not stance.any():
        return np.full(len(times), np.nan)
    z = np.full(len(times), np.nan)
    z[stance] = -(down[stance] * anchor_z[stance]).sum(axis=1) / down[stance].sum(axis=1)
    first, last = np.flatnonzero(stance)[[0, -1]]
    z[:first], z[last + 1:] = z[first], z[last]
    for start, end in _runs(~stance[first:last + 1]):
        a, b = first + start - 1, first + end
        tau, gap = times[a:b + 1] - times[a], times[b] - times[a]
        lift = 0.5 * GRAVITY * tau * (gap - tau) if gap <= MAX_FLIGHT_S else 0.0
        z[a:b + 1] = z[a] + (z[b] - z[a]) * tau / gap + lift
    return z


def _confidence(contact: np.ndarray, times: np.ndarray) -> np.ndarray:
    strength = np.where(contact >= DOWN, contact, 0.0).max(axis=1)
    stance = strength > 0
    confidence = strength.copy()
    if not stance.any():
        return confidence
    first, last = np.flatnonzero(stance)[[0, -1]]
    for start, end in _runs(~stance[first:last + 1]):
        a, b = first + start - 1, first + end
        gap = times[b] - times[a]
        confidence[a + 1:b] = FLIGHT_CONFIDENCE * min(strength[a], strength[b]) * min(1.0, MAX_FLIGHT_S / gap)
    return confidence


def estimate_root_path(points: np.ndarray, contact: np.ndarray, times: np.ndarray,
                       start_xy=(0.0, 0.0), frame_yaw: np.ndarray | None = None) -> RootPath:
    """The root path (see the module docstring) from (T, 2, 8, 3) root-relative sole corners
    (`sole_points`), (T, 2) contact confidences in [0, 1] (right, left) and (T,) frame times;
    `frame_yaw` (T,) turns each frame's pose into the first frame's world (`camera_yaw`)."""
    points = np.asarray(points, np.float64)
    frames = len(times)
    if points.ndim != 4 or points.shape[0] != frames or points.shape[1] != 2 or points.shape[3] != 3 \
            or np.shape(contact) != (frames, 2) or (frame_yaw is not None and np.shape(frame_yaw) != (frames,)):
        raise ValueError(f"root path: expected points (T, 2, K, 3), contact (T, 2) and frame_yaw (T,) for T = {frames} "
                         f"frames, got {points.shape}, {np.shape(contact)}, {None if frame_yaw is None else np.shape(frame_yaw)}")
    if frame_yaw is not None:
        turn = qn.quat_about_axis(np.asarray(frame_yaw, np.float64), np.array([0.0, 0.0, 1.0]))
        points = qn.quat_rotate(np.broadcast_to(turn[:, None, None, :], points.shape[:-1] + (4,)), points)
    contact = smooth_contacts(np.clip(np.asarray(contact, np.float64), 0.0, 1.0))
    times = np.asarray(times, np.float64)
    dt = np.diff(times)
    weights = _anchor_weights(points)
    step_weights = np.minimum(contact[:-1], contact[1:])
    steps, stance = _stance_steps(_foot_steps(points, weights), step_weights, dt)
    steps = _bridge_steps(np.nan_to_num(steps), stance, dt)
    xy = np.asarray(start_xy, np.float64) + np.concatenate((np.zeros((1, 2)), np.cumsum(steps, axis=0)))
    z = _heights(points, weights, contact, times)
    if np.isnan(z).any():  # no contact anywhere: only the pose's lowest point on the floor is known
        z = -points[..., 2].min(axis=(1, 2))
    return RootPath(np.column_stack((xy, z)), _confidence(contact, times))


def motion_root_path(motion, contact: np.ndarray | None = None, turn_by_pan: bool = TURN_BY_PAN) -> RootPath | None:
    """The root path of a reconstructed motion from its pose, its contacts (`contact`, else the
    extras' contact_probability or contacts; None when it has neither) and, with `turn_by_pan`
    where the track measured it, the camera's pan; it starts at the motion's first root position."""
    extras = motion.extras
    if contact is None:
        contact = extras.get("contact_probability", extras.get("contacts"))
    if contact is None:
        return None
    frames = motion.num_frames
    if np.shape(contact) != (frames, 2):
        raise ValueError(f"{motion.source or motion.name}: contacts have shape {np.shape(contact)}, expected ({frames}, 2)")
    yaw = None
    pan, zoom, intrinsics = (extras.get(k) for k in ("camera_pan_px", "camera_zoom", "camera_intrinsics"))
    if turn_by_pan and pan is not None and zoom is not None and intrinsics is not None and len(pan) == len(zoom) == frames:
        yaw = camera_yaw(pan, zoom, float(np.asarray(intrinsics)[0, 0]))
    return estimate_root_path(sole_points(motion.root_rot, motion.joint_rot), np.asarray(contact, np.float64),
                              motion.frame_times, motion.root_pos[0, :2], yaw)


def root_path_extras(motion) -> dict[str, np.ndarray]:
    """{root_path (T, 3), root_path_confidence (T,)} for a motion file; {} without contacts."""
    path = motion_root_path(motion)
    return {} if path is None else {"root_path": path.position, "root_path_confidence": path.confidence}
