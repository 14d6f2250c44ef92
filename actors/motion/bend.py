"""A looped clip played along a turning path: the turning locomotion the DeepMimic clips lack.

NPMP's go-to-target policy (004 §3.4; Merel et al. 2019) steers by choosing latents whose
decoded behaviour turns; its motor module learnt turning from mocap full of it (CMU). The
DeepMimic humanoid3d clips walk and run straight, so a module distilled from them has no
latent that turns, and a go-to policy on it walks past its targets (seen in the rendered
episodes). `bend_motion` makes a turning clip from a straight one by the standard path edit
of motion warping: the clip's own horizontal root steps, each rotated by the yaw the path has
turned so far, and the body rotated by the same yaw about the vertical; joint rotations are
untouched. The foot that is planted while the body turns pivots with it (yaw_rate x stance
time: about 15 degrees at 30 deg/s), which the tracking expert absorbs as DeepMimic's reward
tolerates small foot errors. The result does not loop (a constant turn has no cycle offset
that is a pure translation); it lasts `seconds`.
"""
from __future__ import annotations

import numpy as np

from actors.character import quaternion as qn
from actors.motion.reference_motion import ReferenceMotion

UP = np.array([0.0, 0.0, 1.0])


def bend_motion(motion: ReferenceMotion, yaw_rate: float, seconds: float, name: str | None = None) -> ReferenceMotion:
    """`motion` (a loop, or any clip: it is sampled with its cycle offsets) played for `seconds`
    while its path turns at `yaw_rate` rad/s (positive: to the left, counter-clockwise seen
    from above), at the clip's own frame rate."""
    if not seconds > 0:
        raise ValueError(f"bend_motion: seconds must be positive, got {seconds}")
    times = np.arange(int(round(seconds * motion.fps)) + 1) / motion.fps
    pose = motion.sample(times)
    yaw = yaw_rate * times
    steps = np.diff(pose.root_pos[:, :2], axis=0)
    mid = 0.5 * (yaw[1:] + yaw[:-1])  # each step turned by the path's yaw halfway through it
    c, s = np.cos(mid), np.sin(mid)
    turned = np.stack((c * steps[:, 0] - s * steps[:, 1], s * steps[:, 0] + c * steps[:, 1]), axis=1)
    xy = np.concatenate((pose.root_pos[:1, :2], pose.root_pos[:1, :2] + np.cumsum(turned, axis=0)))
    root_pos = np.column_stack((xy, pose.root_pos[:, 2]))
    root_rot = qn.quat_normalize(qn.quat_mul(qn.quat_about_axis(yaw, UP), pose.root_rot))
    label = name or f"{motion.name.rsplit(':', 1)[-1]}_turn{np.degrees(yaw_rate):+.0f}"  # a file of its own, not deepmimic:<clip>
    return ReferenceMotion(label, times, root_pos, root_rot, pose.joint_rot.copy(), loop=False)
