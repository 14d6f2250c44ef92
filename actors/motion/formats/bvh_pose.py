"""Forward kinematics of any parsed BVH skeleton, in the file's own axes and units.

BVH semantics (as Biovision defined them and players implement them): a joint's frame sits
at its parent's frame plus OFFSET (or plus its position channels, when it has them, which
then replace the OFFSET); its local rotation is the product of its rotation channels in the
order listed (intrinsic). The rest pose is every rotation zero, every joint at its OFFSET.
"""
from __future__ import annotations

import numpy as np

from actors.character import quaternion as qn
from actors.motion.formats.bvh import POSITION_CHANNELS, Bvh, rotation_quats


def local_translations(bvh: Bvh, index: int) -> np.ndarray:
    """(T, 3) translation of a joint in its parent's frame: position channels, else OFFSET."""
    joint = bvh.joints[index]
    frames = len(bvh.frames)
    if not set(POSITION_CHANNELS) <= set(joint.channels):
        return np.broadcast_to(joint.offset, (frames, 3))
    values = bvh.channels_of(index)
    return np.stack([values[:, joint.channels.index(c)] for c in POSITION_CHANNELS], axis=-1)


def bvh_forward_kinematics(bvh: Bvh) -> tuple[np.ndarray, np.ndarray]:
    """Global joint positions (T, J, 3) and rotations (T, J, 4 wxyz), file axes and units."""
    frames, count = len(bvh.frames), len(bvh.joints)
    pos = np.empty((frames, count, 3))
    rot = np.empty((frames, count, 4))
    for index, joint in enumerate(bvh.joints):  # depth first: a parent always comes first
        local_rot = rotation_quats(bvh, index)
        local_pos = local_translations(bvh, index)
        if joint.parent < 0:
            pos[:, index], rot[:, index] = local_pos, local_rot
        else:
            parent_rot = rot[:, joint.parent]
            pos[:, index] = pos[:, joint.parent] + qn.quat_rotate(parent_rot, local_pos)
            rot[:, index] = qn.quat_mul(parent_rot, local_rot)
    return pos, qn.quat_normalize(rot)


def rest_positions(bvh: Bvh) -> np.ndarray:
    """(J, 3) joint positions in the rest pose (zero rotations, OFFSETs), root at its OFFSET."""
    pos = np.empty((len(bvh.joints), 3))
    for index, joint in enumerate(bvh.joints):
        pos[index] = joint.offset + (pos[joint.parent] if joint.parent >= 0 else 0.0)
    return pos


def rest_tip(bvh: Bvh, index: int, rest: np.ndarray) -> np.ndarray | None:
    """Where a joint's bone ends in the rest pose: its End Site, else its first child, else None."""
    joint = bvh.joints[index]
    if joint.end_site is not None:
        return rest[index] + joint.end_site
    child = next((i for i, j in enumerate(bvh.joints) if j.parent == index), None)
    return None if child is None else rest[child]
