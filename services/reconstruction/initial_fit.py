"""The 3D prediction as humanoid poses: a per-frame fit of joint rotations to BlazePose's
world landmarks (SFV's q_hat_t).

The person's bones are longer or shorter than the humanoid's, so the fit matches bone
directions, not positions: for every bone in `FIT_BONES`, the unit vector between its two
points on the humanoid should equal the one in the prediction. All frames are fitted at
once (a batch of independent problems) with Adam, joints clamped to their limits after
every step. A weak pull towards the rest pose settles rotations no bone direction sees
(a straight arm's twist).
"""
from __future__ import annotations

import numpy as np
import torch
from scipy.spatial.transform import Rotation

from actors.character.skeleton import JOINT_NAMES, REVOLUTE_JOINTS
from services.reconstruction.body import REVOLUTE_LIMITS, PoseParams, body_points
from services.reconstruction.keypoints import FIT_BONES, fit_index

REST_PULL = 1e-3


def _point(points, name: str):
    """A named fit point, or the pelvis / thorax midpoints, from (..., P, 3)."""
    if name == "pelvis":
        return 0.5 * (points[..., fit_index("RHip"), :] + points[..., fit_index("LHip"), :])
    if name == "thorax":
        return 0.5 * (points[..., fit_index("RShoulder"), :] + points[..., fit_index("LShoulder"), :])
    return points[..., fit_index(name), :]


def bone_directions(points):
    """Unit bone vectors (..., B, 3) of `FIT_BONES` (numpy or torch input)."""
    if isinstance(points, torch.Tensor):
        vectors = torch.stack([_point(points, b) - _point(points, a) for a, b in FIT_BONES], dim=-2)
        return vectors / vectors.norm(dim=-1, keepdim=True).clamp_min(1e-9)
    vectors = np.stack([_point(points, b) - _point(points, a) for a, b in FIT_BONES], axis=-2)
    return vectors / np.maximum(np.linalg.norm(vectors, axis=-1, keepdims=True), 1e-9)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-9)


def initial_root_quats(points: np.ndarray) -> np.ndarray:
    """Root rotations (T, 4 wxyz) from the pelvis: +y towards the left hip, +z towards the thorax."""
    left = _unit(_point(points, "LHip") - _point(points, "RHip"))
    up = _unit(_point(points, "thorax") - _point(points, "pelvis"))
    forward = _unit(np.cross(left, up))
    up = np.cross(forward, left)
    matrices = np.stack((forward, left, up), axis=-1)
    return np.roll(Rotation.from_matrix(matrices).as_quat(), 1, axis=-1)  # xyzw -> wxyz


def _bend_angle(points: np.ndarray, a: str, b: str, c: str) -> np.ndarray:
    first, second = _unit(_point(points, b) - _point(points, a)), _unit(_point(points, c) - _point(points, b))
    return np.arccos(np.clip((first * second).sum(-1), -1.0, 1.0))


def initial_revolute(points: np.ndarray) -> np.ndarray:
    """Knee and elbow angles (T, 4) from the angle between the two bones they join
    (knees bend negatively, elbows positively, see the joint limits)."""
    bends = {
        "right_knee": -_bend_angle(points, "RHip", "RKnee", "RAnkle"),
        "left_knee": -_bend_angle(points, "LHip", "LKnee", "LAnkle"),
        "right_elbow": _bend_angle(points, "RShoulder", "RElbow", "RWrist"),
        "left_elbow": _bend_angle(points, "LShoulder", "LElbow", "LWrist"),
    }
    angles = np.stack([bends[JOINT_NAMES[j]] for j in REVOLUTE_JOINTS], axis=-1)
    return np.clip(angles, REVOLUTE_LIMITS[:, 0], REVOLUTE_LIMITS[:, 1])


def fit_poses_to_points(points_world: np.ndarray, iterations: int, lr: float,
                        dtype: torch.dtype = torch.float64) -> PoseParams:
    """Humanoid poses (root at the origin) whose bone directions match points (T, P, 3)."""
    frames = len(points_world)
    params = PoseParams.create(np.zeros((frames, 3)), initial_root_quats(points_world),
                               np.zeros((frames, 8, 3)), initial_revolute(points_world), dtype)
    params.root_pos.requires_grad_(False)
    target = torch.as_tensor(bone_directions(points_world), dtype=dtype)
    optimiser = torch.optim.Adam(params.rotation_leaves(), lr=lr)
    decay = torch.optim.lr_scheduler.ExponentialLR(optimiser, gamma=0.05 ** (1.0 / max(iterations, 1)))
    for _ in range(iterations):
        optimiser.zero_grad(set_to_none=True)
        fit, _ = body_points(params.root_pos, params.root_quat(), params.joint_quats())
        error = ((bone_directions(fit) - target) ** 2).sum(-1).sum(-1)
        rest = (params.spherical ** 2).sum((-1, -2))
        loss = (error + REST_PULL * rest).sum()
        loss.backward()
        optimiser.step()
        decay.step()
        params.clamp_to_limits()
    params.fold_root_rotation()
    return params


