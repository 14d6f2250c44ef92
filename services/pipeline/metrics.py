"""The measures a pipeline report gives of a motion (simulated or kinematic), in plain numpy.

Every function takes per-frame arrays and returns numbers in SI units (metres, m/s, pixels):

- joint_position_errors: per-frame mean distance (m) between two sets of joint positions
  (T, J, 3), in the world (the root's path included) or root-relative (`centre` joints'
  mean subtracted per frame first).
- lowest_points / foot heights: the lowest point of each foot geom above the floor.
- foot_contacts: a foot is in contact where its lowest point is within CONTACT_HEIGHT_M of
  the floor (one geometric rule, so a kinematic motion and a simulation are judged alike).
- foot_skating: mean horizontal speed (m/s) of the feet over the frame pairs in which the foot
  is in contact at both ends (0 for a planted foot; the speed of a sliding one).
- ground_penetration: per frame, how far (m) the lowest point of the body is below the floor.
- reprojection_errors: per-frame confidence-weighted mean pixel distance between 3D joints
  projected through a pinhole camera and the video's 2D keypoints; a joint less than
  MIN_DEPTH_M in front of the camera (or behind it) has no image and is not scored
  (`behind_camera` counts them): a character thrown behind the camera read as 2.0e9 px.
- aligned_joint_errors: joint_position_errors after one rigid motion (a turn about the vertical
  and a shift) that best lays the whole simulated path onto the reference's: a controller that
  walks beside the path, or turned a little at the start, is not read as metres of error.
"""
from __future__ import annotations

import numpy as np

CONTACT_HEIGHT_M = 0.02  # a foot whose lowest point is this close to the floor is on it
MIN_CONFIDENCE = 0.3  # 2D keypoints below this confidence are not scored (as drawn)
MIN_DEPTH_M = 0.1  # a joint nearer the camera's plane than this has no meaningful image


def summary(values: np.ndarray) -> dict:
    """{"mean", "max"} of a per-frame array (None for an empty one)."""
    values = np.asarray(values, np.float64)
    if values.size == 0:
        return {"mean": None, "max": None}
    return {"mean": float(values.mean()), "max": float(values.max())}


def joint_position_errors(simulated: np.ndarray, reference: np.ndarray, centre: list[int] | None = None) -> np.ndarray:
    """(T,) mean joint distance per frame between (T, J, 3) arrays; with `centre` (joint indices),
    each frame's mean of those joints is subtracted from both first (root-relative)."""
    simulated, reference = np.asarray(simulated, np.float64), np.asarray(reference, np.float64)
    if simulated.shape != reference.shape:
        raise ValueError(f"joint arrays differ in shape: {simulated.shape} vs {reference.shape}")
    if centre is not None:
        simulated = simulated - simulated[:, centre].mean(axis=1, keepdims=True)
        reference = reference - reference[:, centre].mean(axis=1, keepdims=True)
    return np.linalg.norm(simulated - reference, axis=-1).mean(axis=1)


def aligned_joint_errors(simulated: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(T,) joint_position_errors after the one turn about z and shift (over all frames and
    joints, least squares: Kabsch in the horizontal plane, mean height) that lays `simulated`
    on `reference`."""
    sim, ref = np.asarray(simulated, np.float64), np.asarray(reference, np.float64)
    a, b = sim.reshape(-1, 3), ref.reshape(-1, 3)
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    u, v = a[:, :2] - ca[:2], b[:, :2] - cb[:2]
    angle = np.arctan2((u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]).sum(), (u * v).sum())
    turn = np.array([[np.cos(angle), -np.sin(angle), 0.0], [np.sin(angle), np.cos(angle), 0.0], [0.0, 0.0, 1.0]])
    aligned = (sim - ca) @ turn.T + cb
    return joint_position_errors(aligned, ref)


def box_lowest_z(centre: np.ndarray, rotation: np.ndarray, half_size: np.ndarray) -> np.ndarray:
    """Lowest z of boxes: centre (..., 3), rotation (..., 3, 3) body->world, half extents (..., 3)."""
    return centre[..., 2] - (np.abs(rotation[..., 2, :]) * half_size).sum(axis=-1)


def foot_contacts(foot_heights: np.ndarray, threshold: float = CONTACT_HEIGHT_M) -> np.ndarray:
    """(T, F) bool: the foot's lowest point at most `threshold` above the floor."""
    return np.asarray(foot_heights) <= threshold


def foot_skating(foot_positions: np.ndarray, contacts: np.ndarray, fps: float) -> float | None:
    """Mean horizontal speed (m/s) of feet (T, F, 3) over the frame pairs in which the foot is
    in contact at both frames (`contacts` (T, F)); None when no foot stays in contact a pair."""
    positions = np.asarray(foot_positions, np.float64)
    contacts = np.asarray(contacts, bool)
    if len(positions) < 2:
        return None
    speed = np.linalg.norm(np.diff(positions[..., :2], axis=0), axis=-1) * float(fps)  # (T-1, F)
    held = contacts[1:] & contacts[:-1]
    return float(speed[held].mean()) if held.any() else None


def ground_penetration(lowest_heights: np.ndarray) -> np.ndarray:
    """(T,) depth (m, >= 0) of the lowest point below the floor, from (T, G) heights above it."""
    lowest = np.asarray(lowest_heights, np.float64)
    if lowest.ndim > 1:
        lowest = lowest.min(axis=tuple(range(1, lowest.ndim)))
    return np.maximum(0.0, -lowest)


def project_points(points: np.ndarray, rotation: np.ndarray, position: np.ndarray, intrinsics: np.ndarray) -> np.ndarray:
    """(..., 3) world points -> (..., 2) pixels of a pinhole camera (rotation world -> camera,
    camera centre `position`, intrinsics K); points behind the camera are clamped to its plane."""
    cam = (np.asarray(points, np.float64) - position) @ np.asarray(rotation).T
    return cam[..., :2] / np.maximum(cam[..., 2:], 1e-6) * np.diag(intrinsics)[:2] + np.asarray(intrinsics)[:2, 2]


def depths(points: np.ndarray, rotation, position) -> np.ndarray:
    """(...) distance of world points (..., 3) in front of the camera's plane (negative: behind)."""
    return ((np.asarray(points, np.float64) - position) @ np.asarray(rotation).T)[..., 2]


def behind_camera(points: np.ndarray, rotation, position) -> np.ndarray:
    """(T,) bool: some joint of (T, J, 3) is behind the camera or within MIN_DEPTH_M of its plane."""
    return (depths(points, rotation, position) < MIN_DEPTH_M).any(axis=-1)


def reprojection_errors(points: np.ndarray, keypoints2d: np.ndarray, confidence: np.ndarray, rotation, position,
                        intrinsics, min_confidence: float = MIN_CONFIDENCE) -> np.ndarray:
    """(T,) per-frame confidence-weighted mean distance (px) between (T, J, 3) joints projected
    through the camera and (T, J, 2) keypoints; keypoints under `min_confidence` and joints
    behind the camera (`behind_camera`) do not count (a frame without any: NaN)."""
    pixels = project_points(points, rotation, position, intrinsics)
    distance = np.linalg.norm(pixels - np.asarray(keypoints2d, np.float64), axis=-1)
    seen = (np.asarray(confidence) >= min_confidence) & (depths(points, rotation, position) >= MIN_DEPTH_M)
    weights = np.where(seen, np.asarray(confidence, np.float64), 0.0)
    total = weights.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(total > 0, (weights * distance).sum(axis=1) / np.where(total > 0, total, 1.0), np.nan)
