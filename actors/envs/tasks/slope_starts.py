"""A task episode's start on a slope: turned to a random heading and set down on the incline.

The clip frames of `ClipStarts` face the clips' own way and stand on the flat floor at the
origin. On a slope fixed along world +x (`actors/arenas/slope.py`) those starts would always
face the same way up or down it, so the start is turned about the vertical through its root by
a uniform yaw (the free joint's world-frame linear velocity turns with it; its angular velocity
is in the root's frame and does not change). It is then raised by the highest ground under any
of its geoms, so no geom is closer to the incline than it was to the flat floor: on a 15 %
grade a walking stride's front foot, 0.4 m ahead, would be 6 cm into the slope, and the solver
would throw it out. The lower foot then drops the few centimetres onto the ground below it.
"""
from __future__ import annotations

import mujoco
import numpy as np

from actors.character.quaternion import quat_mul


def turn_start(qpos: np.ndarray, qvel: np.ndarray, yaw: float) -> None:
    """Turn a free-root state (qpos[:7], qvel[:3] world linear velocity) by `yaw` about the
    vertical through its root, in place."""
    half = 0.5 * yaw
    qpos[3:7] = quat_mul(np.array([np.cos(half), 0.0, 0.0, np.sin(half)]), qpos[3:7])
    c, s = np.cos(yaw), np.sin(yaw)
    vx, vy = qvel[0], qvel[1]
    qvel[0], qvel[1] = c * vx - s * vy, s * vx + c * vy


def set_down(ground, model: mujoco.MjModel, data: mujoco.MjData, geoms: np.ndarray) -> float:
    """Raise the root (qpos[2]) by the highest ground height under the centres of `geoms` (the
    walker's) less the flat floor's zero, after forward kinematics; returns the lift (m)."""
    mujoco.mj_kinematics(model, data)
    lift = max(float(np.max(ground.height_at(data.geom_xpos[geoms, :2]))), 0.0)
    data.qpos[2] += lift
    return lift
