"""Motions from a moving camera: joint rotations kept, the root path not to be tracked.

With a camera that pans, tilts or zooms, the person's image position and scale mix their
own motion with the camera's, so the root trajectory SFV section 6 reads from them is not
the person's. movingcam (002 section 5.1) therefore leaves the root to the simulation: its
imitation reward compares joint angles and velocities and the body-orientation hint, never
the root position. The reconstruction still fits every frame (the fit needs a root), then
the horizontal root position is held at its first value so that nothing downstream mistakes
it for a path, and the file is flagged `root_free` (see `actors.motion.formats.io`). Height and the
root's rotation are kept: the ground and the body's up direction still constrain them.
"""
from __future__ import annotations

import numpy as np

from actors.motion.reference_motion import ReferenceMotion

POSITION_EXTRAS = ("keypoints3d", "raw_keypoints3d")


def make_root_free(motion: ReferenceMotion) -> ReferenceMotion:
    """The same motion with its horizontal root path removed, flagged root-free."""
    drift = motion.root_pos[:, :2] - motion.root_pos[:1, :2]  # (T, 2)
    root_pos = motion.root_pos.copy()
    root_pos[:, :2] -= drift
    extras = dict(motion.extras)
    for name in POSITION_EXTRAS:  # joints move rigidly with the root's translation
        if name in extras:
            points = np.array(extras[name], dtype=np.float64)
            points[..., :2] -= drift[:, None, :]
            extras[name] = points
    extras["root_free"] = np.array(True)
    return ReferenceMotion(motion.name, motion.frame_times, root_pos, motion.root_rot, motion.joint_rot,
                           motion.loop, extras)
