"""Forward kinematics of the humanoid in batched, differentiable torch: the mirror of
`actors.character.kinematics.forward_kinematics` that motion reconstruction optimises through (same
pose layout, same results; a test checks them against each other)."""
from __future__ import annotations

import torch

from actors.character.skeleton import HINGE_AXIS, LINK_JOINT, NUM_LINKS, OFFSETS, PARENTS, REVOLUTE_JOINTS, SPHERICAL_JOINTS
from services.reconstruction import quaternion_torch as qt


def forward_kinematics_torch(root_pos: torch.Tensor, root_quat: torch.Tensor, joint_quats: torch.Tensor):
    """Torch version of `forward_kinematics`; gradients flow to all three inputs."""
    offsets = torch.as_tensor(OFFSETS, dtype=root_pos.dtype, device=root_pos.device)
    positions = [root_pos]
    rotations = [root_quat]
    for link in range(1, NUM_LINKS):
        parent = int(PARENTS[link])
        parent_rot = rotations[parent]
        positions.append(positions[parent] + qt.quat_rotate(parent_rot, offsets[link].expand_as(root_pos)))
        joint = int(LINK_JOINT[link])
        rotations.append(parent_rot if joint < 0 else qt.quat_mul(parent_rot, joint_quats[..., joint, :]))
    return torch.stack(positions, dim=-2), torch.stack(rotations, dim=-2)


def joint_quats_from_params_torch(spherical_rotvecs: torch.Tensor, revolute_angles: torch.Tensor) -> torch.Tensor:
    """Build the (..., 12, 4) joint quaternions from free parameters an optimiser can own.

    spherical_rotvecs: (..., 8, 3) rotation vectors of the spherical joints (exp map),
    revolute_angles: (..., 4) hinge angles, both in skeleton order.
    """
    batch = revolute_angles.shape[:-1]
    quats = revolute_angles.new_zeros(batch + (len(SPHERICAL_JOINTS) + len(REVOLUTE_JOINTS), 4))
    axis = torch.as_tensor(HINGE_AXIS, dtype=revolute_angles.dtype, device=revolute_angles.device)
    quats = quats.index_copy(-2, torch.as_tensor(SPHERICAL_JOINTS), qt.quat_from_axis_angle(spherical_rotvecs))
    return quats.index_copy(-2, torch.as_tensor(REVOLUTE_JOINTS), qt.quat_about_axis(revolute_angles, axis))
