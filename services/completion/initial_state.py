"""The simulated character's first state: q_bar, turned to the reference's heading at the
chosen row, moving with that row's velocities (a still image has none, SFV section 8).

The root's horizontal position comes from the reference row (ImitationEnv's "state" init).
Its height first puts the feet on the ground; if another body part would then be below
the floor (a kneeling or lying actor) the body is lifted until nothing penetrates, found
with MuJoCo's own contacts against the floor.
"""
from __future__ import annotations

import mujoco
import numpy as np

from actors.character import quaternion as qn
from actors.envs.imitation_env import ImitationEnv
from actors.character.skeleton import revolute_angle

_UP = np.array([0.0, 0.0, 1.0])


def target_qpos(env: ImitationEnv, row: int, root_rot: np.ndarray, joint_rot: np.ndarray, root_height: float,
                yaw: float) -> np.ndarray:
    """qpos of q_bar (root (4,), joints (12, 4)) turned by `yaw`, at the reference row's xy."""
    layout = env.layout
    qpos = env.track.qpos[row].copy()
    qpos[2] = root_height
    qpos[3:7] = qn.quat_normalize(qn.quat_mul(qn.quat_about_axis(yaw, _UP), root_rot))
    qpos[layout.ball_qpos] = joint_rot[layout.spherical]
    qpos[layout.hinge_qpos] = revolute_angle(joint_rot[layout.revolute])
    return qpos


def lift_out_of_floor(model: mujoco.MjModel, qpos: np.ndarray, margin: float = 0.0) -> float:
    """Raise qpos's root (in place) so that no geom is deeper than `margin` in the floor; the lift in metres."""
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    deepest = min((data.contact[i].dist for i in range(data.ncon)), default=0.0)
    lift = max(0.0, -deepest - margin)
    qpos[2] += lift
    return lift


def initial_state(env: ImitationEnv, row: int, root_rot: np.ndarray, joint_rot: np.ndarray, root_height: float,
                  yaw: float) -> np.ndarray:
    """ASI-style state vector (qpos[2:] + qvel) for `env.reset(options={"init": "state", ...})`."""
    qpos = target_qpos(env, row, root_rot, joint_rot, root_height, yaw)
    lift_out_of_floor(env.model, qpos)
    return env.layout.state_vector(qpos, env.track.qvel[row])
