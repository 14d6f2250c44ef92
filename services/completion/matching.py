"""Which reference frame is closest to q_bar (SFV eq. 8: argmin over runs i and frames t of
||q_bar - q_t^i||).

The distance is the sum over the 12 joints of the angle of the rotation between their local
rotations, plus the root's: the root angle is taken after the best turn about the vertical,
because a still image's heading (which way the camera looked) says nothing about the
motion's. For unit quaternions a (reference) and b (image) turned by yaw psi,
R_z(psi) = (cos psi/2, 0, 0, sin psi/2), the real part of a^-1 R_z(psi) b is
w(psi) = (a . b) cos psi/2 + (a . k b) sin psi/2, so the smallest angle over all yaws is
2 acos(sqrt((a . b)^2 + (a . k b)^2)), reached at psi = 2 atan2(a . k b, a . b).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from actors.character import quaternion as qn

_UNIT_Z = np.array([0.0, 0.0, 0.0, 1.0])  # the pure quaternion k


def rotation_angle_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle (radians, [0, pi]) of the rotation taking unit quaternions a to b (..., 4) -> (...)."""
    return 2.0 * np.arccos(np.clip(np.abs((a * b).sum(-1)), 0.0, 1.0))


def yaw_free_root(reference: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(angle, yaw): the root rotation angle between `reference` (..., 4) and `target` (4,)
    after turning the target about the world vertical by `yaw`, the yaw that minimises it."""
    along = (reference * target).sum(-1)
    across = (reference * qn.quat_mul(_UNIT_Z, target)).sum(-1)
    angle = 2.0 * np.arccos(np.clip(np.hypot(along, across), 0.0, 1.0))
    return angle, 2.0 * np.arctan2(across, along)


def pose_distances(target_root: np.ndarray, target_joints: np.ndarray, root_rot: np.ndarray,
                   joint_rot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distances (N,) of q_bar (root (4,), joints (12, 4)) to N reference poses (root (N, 4),
    joints (N, 12, 4)), and the yaw (N,) that aligns q_bar's heading with each."""
    root_angle, yaw = yaw_free_root(root_rot, target_root)
    joint_angle = rotation_angle_between(joint_rot, target_joints).sum(-1)
    return root_angle + joint_angle, yaw


@dataclass(frozen=True)
class Match:
    skill: int  # index into the library
    row: int  # control-step row of that skill's reference track
    distance: float  # radians, summed over root and joints
    yaw: float  # radians: turning q_bar by this about the vertical lines it up with the reference


def best_match(target_root: np.ndarray, target_joints: np.ndarray, references) -> tuple[Match, list[Match]]:
    """The closest (skill, row) over `references`, a sequence of (root (N_i, 4), joints (N_i, 12, 4));
    also every skill's own best, in library order."""
    per_skill = []
    for index, (root_rot, joint_rot) in enumerate(references):
        distances, yaw = pose_distances(target_root, target_joints, root_rot, joint_rot)
        row = int(np.argmin(distances))
        per_skill.append(Match(index, row, float(distances[row]), float(yaw[row])))
    return min(per_skill, key=lambda m: m.distance), per_skill
