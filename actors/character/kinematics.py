"""Forward kinematics of the humanoid in numpy (the torch mirror, for reconstruction, is
`services/reconstruction/kinematics_torch.py`).

A pose is the root position (..., 3), the root rotation (..., 4) and the local rotation of
each of the 12 joints as a quaternion (..., 12, 4) in `skeleton.JOINT_NAMES` order (revolute
joints as rotations about `skeleton.HINGE_AXIS`). The result is the world position and
rotation of every link frame (..., 15, 3) and (..., 15, 4) in `skeleton.LINK_NAMES` order; a
link frame sits at its joint, so these equal MuJoCo's `xpos` / `xquat` of the same bodies.
"""
from __future__ import annotations

import numpy as np

from actors.character import quaternion as qn
from actors.character.skeleton import LINK_JOINT, NUM_LINKS, OFFSETS, PARENTS, revolute_angle  # noqa: F401 (re-export)


def forward_kinematics(root_pos: np.ndarray, root_quat: np.ndarray, joint_quats: np.ndarray):
    """World link positions (..., 15, 3) and rotations (..., 15, 4)."""
    batch = root_pos.shape[:-1]
    pos = np.empty(batch + (NUM_LINKS, 3))
    rot = np.empty(batch + (NUM_LINKS, 4))
    pos[..., 0, :] = root_pos
    rot[..., 0, :] = root_quat
    for link in range(1, NUM_LINKS):
        parent = PARENTS[link]
        parent_rot = rot[..., parent, :]
        pos[..., link, :] = pos[..., parent, :] + qn.quat_rotate(parent_rot, np.broadcast_to(OFFSETS[link], batch + (3,)))
        joint = LINK_JOINT[link]
        rot[..., link, :] = parent_rot if joint < 0 else qn.quat_mul(parent_rot, joint_quats[..., joint, :])
    return pos, rot
