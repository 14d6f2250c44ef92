"""Closing a looped clip: its last pose made equal to its first, the mismatch blended away.

A looped clip plays its last frame and then, at the same instant, its first frame again
(DeepMimic's convention: the last frame is the first one shifted by the cycle's root offset).
Mocap loops are rarely closed that well: on the DeepMimic clips the largest joint mismatch at
the wrap is 1.01 rad on the spinkick, .61 on the crawl, .50 on the walk, .47 on the cartwheel
(5.5x its 95th-percentile change between frames), .36 on the jump, .30-.34 on the dances
(`wrap_mismatch`). The reference then jumps in one instant and the tracking reward asks for the
jump; the cartwheel's remaining falls sit 0.4-0.55 s after its wrap.

Pure PD tracking from 10 reference starts 0.3-0.03 s before the wrap (zero residual, 60 steps
at most), control steps survived and end-effector term, open / closed over 0.3 s: walk 37 / 43,
.64 / .72; cartwheel 47 / 41, .36 / .57; spinkick 35 / 31, .41 / .36; jump 32 / 30, .85 / .84;
dance_a 31 / 30; crawl 60 / 60. Mixed: PD tracking alone does not say whether a policy learns
the wrap better, so closing is an option (`EnvConfig.loop_closure_s`, off) until trainings say.

`close_loop` splits each joint's mismatch r (the rotation from the last pose to the first, in
the joint's frame) between the two ends: the last `blend_s` seconds turn by up to +r/2, the
first `blend_s` seconds by up to -r/2, with a smoothstep weight, so the two ends meet halfway
and the clip is unchanged in between. The root's tilt is closed the same way; its heading and
position are left as they are (the cycle's root offset carries them, as in DeepMimic).
Velocities are recomputed from the closed poses (central differences across the wrap).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from actors.character import quaternion as qn
from actors.motion.reference_motion import ReferenceMotion


def wrap_mismatch(motion: ReferenceMotion) -> np.ndarray:
    """(12,) angle in rad between each joint's last and first rotation (0 for a closed loop)."""
    delta = qn.quat_mul(qn.quat_conj(motion.joint_rot[-1]), motion.joint_rot[0])
    return qn.quat_angle(delta)


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _end_weights(times: np.ndarray, duration: float, blend_s: float) -> np.ndarray:
    """(T,) fraction of the mismatch each frame turns by: -1/2 at the first frame rising to 0
    after blend_s, 0 in the middle, 0 rising to +1/2 over the last blend_s."""
    head = -0.5 * _smoothstep(1.0 - times / blend_s)
    tail = 0.5 * _smoothstep((times - (duration - blend_s)) / blend_s)
    return head + tail


def _tilt(root_rot: np.ndarray) -> np.ndarray:
    """The root rotation with its heading taken out: heading^-1 * q."""
    return qn.quat_mul(qn.quat_conj(qn.heading_quat(root_rot)), root_rot)


def close_loop(motion: ReferenceMotion, blend_s: float) -> ReferenceMotion:
    """The clip with its wrap closed over `blend_s` seconds at each end (unchanged when it does
    not loop or blend_s is 0; blend_s is capped at half the clip)."""
    if not motion.loop or blend_s <= 0.0 or motion.num_frames < 3:
        return motion
    joint_r = qn.quat_to_axis_angle(qn.quat_mul(qn.quat_conj(motion.joint_rot[-1]), motion.joint_rot[0]))  # (joints, 3)
    tilt = _tilt(motion.root_rot[[0, -1]])
    root_r = qn.quat_to_axis_angle(qn.quat_mul(qn.quat_conj(tilt[1]), tilt[0]))  # (3,)
    if max(np.abs(joint_r).max(), np.abs(root_r).max()) < 1e-9:  # closed already (e.g. closed once before)
        return motion
    blend_s = min(float(blend_s), 0.5 * motion.duration)
    weights = _end_weights(motion.frame_times, motion.duration, blend_s)
    joint_rot = qn.quat_mul(motion.joint_rot, qn.quat_from_axis_angle(weights[:, None, None] * joint_r[None]))
    root_rot = qn.quat_mul(motion.root_rot, qn.quat_from_axis_angle(weights[:, None] * root_r[None]))
    return dataclasses.replace(motion, joint_rot=qn.quat_normalize(joint_rot), root_rot=qn.quat_normalize(root_rot))
