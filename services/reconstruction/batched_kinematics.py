"""Forward kinematics for long batches of frames inside an optimiser loop.

Same result as `services.reconstruction.kinematics_torch.forward_kinematics_torch` (a test checks it), computed
with rotation matrices one tree level at a time: 5 batched steps instead of 14 chained
quaternion products. The optimisation runs it hundreds of times over every frame of a
clip, and torch's per-operation overhead, not arithmetic, is what costs there.
"""
from __future__ import annotations

import numpy as np
import torch

from actors.character.skeleton import LINK_JOINT, NUM_LINKS, OFFSETS, PARENTS


def _depths() -> np.ndarray:
    depth = np.zeros(NUM_LINKS, dtype=int)
    for link in range(1, NUM_LINKS):
        depth[link] = depth[PARENTS[link]] + 1
    return depth


_DEPTH = _depths()
LEVELS: tuple[np.ndarray, ...] = tuple(np.flatnonzero(_DEPTH == d) for d in range(_DEPTH.max() + 1))
# A link's parent sits one level up; its index inside that level's list:
PARENT_IN_LEVEL: tuple[torch.Tensor, ...] = tuple(
    torch.tensor([list(LEVELS[d - 1]).index(PARENTS[link]) for link in LEVELS[d]]) for d in range(1, len(LEVELS)))
LEVEL_LINKS: tuple[torch.Tensor, ...] = tuple(torch.as_tensor(level) for level in LEVELS)
# Where each link lands when the levels are concatenated, to restore skeleton order.
SKELETON_ORDER = torch.as_tensor(np.argsort(np.concatenate(LEVELS)))
# index_select (backward: index_add) rather than advanced indexing (backward: index_put with
# accumulation), which is several times slower on CPU for these shapes.


# Row of cat(joint matrices, identity) that holds each link's local rotation (identity for
# the root, whose rotation is set separately, and the fixed wrists).
_LOCAL_SOURCE = torch.as_tensor(np.where(LINK_JOINT < 0, len(np.flatnonzero(LINK_JOINT >= 0)), LINK_JOINT))


def quat_to_matrix(q: torch.Tensor) -> torch.Tensor:
    """(..., 4) wxyz unit quaternions -> (..., 3, 3) rotation matrices."""
    w, x, y, z = q.unbind(-1)
    rows = (
        1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
        2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
        2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y),
    )
    return torch.stack(rows, dim=-1).reshape(q.shape[:-1] + (3, 3))


def matmul3(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Batched product of small matrices as one broadcast multiply and sum (torch's bmm
    spends far longer per 3x3 matrix on CPU)."""
    return (a.unsqueeze(-1) * b.unsqueeze(-3)).sum(-2)


def link_frames(root_pos: torch.Tensor, root_quat: torch.Tensor, joint_quats: torch.Tensor):
    """World link positions (..., 15, 3) and rotation matrices (..., 15, 3, 3)."""
    batch = root_pos.shape[:-1]
    identity = torch.eye(3, dtype=root_pos.dtype).expand(batch + (1, 3, 3))
    # Local rotation of every link relative to its parent: the joint's rotation, identity for the fixed wrists.
    joint_mats = quat_to_matrix(joint_quats)
    local = torch.cat((joint_mats, identity), dim=-3).index_select(-3, _LOCAL_SOURCE)
    offsets = torch.as_tensor(OFFSETS, dtype=root_pos.dtype)
    level_rot = [quat_to_matrix(root_quat).unsqueeze(-3)]
    level_pos = [root_pos.unsqueeze(-2)]
    for level, parent_index in zip(LEVEL_LINKS[1:], PARENT_IN_LEVEL):
        parent_rot = level_rot[-1].index_select(-3, parent_index)
        level_pos.append(level_pos[-1].index_select(-2, parent_index) + (parent_rot * offsets[level].unsqueeze(-2)).sum(-1))
        level_rot.append(matmul3(parent_rot, local.index_select(-3, level)))
    positions = torch.cat(level_pos, dim=-2).index_select(-2, SKELETON_ORDER)
    rotations = torch.cat(level_rot, dim=-3).index_select(-3, SKELETON_ORDER)
    return positions, rotations
