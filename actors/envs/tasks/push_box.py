"""Reach a box and push it to a target (NPMP 004 §3.4's warehouse, reduced to pushing).

004's warehouse phases are GOTO, LIFT, CARRY, PUTDOWN with sparse rewards per phase; the
motor modules built here come from locomotion clips (no grasping), so the task keeps the first
and the spirit of the third: walk to the box, then move it to a target on the floor by pushing
(`actors/arenas/push_box.py`). Per episode the box stands U(box_distance) m ahead of the
character (within +-45 deg of its heading) and its target U(box_target_distance) m beyond
it (within +-45 deg of the walker-to-box direction). Reward per step, in [0, 1]:
    0.2 approach + 0.2 near + 0.3 push + 0.3 exp(-|target - box|)
approach: exp(-2 (v_toward_box - 1)^2) while farther than 0.7 m from the box, else 1; near:
exp(-2 max(d_box - 0.6, 0)^2); push: the box's speed toward its target, clipped to [0, 1] m/s.
The box within `success_radius` of its target adds `success_bonus` and a new target is drawn
beyond the box. Task features (11, heading frame): box x, y, distance, box yaw cos, sin; box
velocity x, y; target x, y from the root; target x, y from the box.

On SFV Fig. 8's slope (`--env.slope`, `actors/arenas/slope.py`) the box is set down flush on
the incline at its yaw, and its yaw is read from its x axis (a box resting on a slope is not
a pure yaw rotation). Everything the task measures stays in the horizontal plane.
"""
from __future__ import annotations

import mujoco
import numpy as np

from actors.arenas.push_box import BOX_BODY, PushBoxArena
from actors.arenas.slope import task_floor
from actors.character.quaternion import quat_mul
from actors.envs.tasks.geometry import polar, to_heading_frame, wrap_angle

NEAR_M, APPROACH_M, PUSH_SPEED = 0.6, 0.7, 1.0


class PushBoxTask:
    obs_dim = 11

    @staticmethod
    def arena_for(config) -> PushBoxArena:
        return PushBoxArena(floor=task_floor(config.slope))

    def __init__(self, config, num_envs: int, model: mujoco.MjModel | None = None):
        self.config = config
        self.arena = self.arena_for(config)
        self._tilt = self.arena.floor.tilt_quat  # a box set down flush on the ground
        self._lift = self.arena.half_size[2] / np.cos(np.arctan(self.arena.grade))  # the centre above the incline, flush
        self.target = np.zeros((num_envs, 2))
        self.box = np.zeros((num_envs, 3))
        self.box_vel = np.zeros((num_envs, 2))
        self.box_yaw = np.zeros(num_envs)
        if model is not None:
            joint = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "box_root")
            self.qpos_adr, self.qvel_adr = int(model.jnt_qposadr[joint]), int(model.jnt_dofadr[joint])
            self.body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, BOX_BODY)

    def reset(self, i: int, root_xy: np.ndarray, yaw: float, rng: np.random.Generator, data=None) -> None:
        box_xy = root_xy + polar(rng, self.config.box_distance, yaw, np.pi / 4)
        self._place_box(i, root_xy, box_xy, self._lift, rng, data)

    def _place_box(self, i: int, root_xy: np.ndarray, box_xy: np.ndarray, lift: float, rng: np.random.Generator, data) -> None:
        """The box at `box_xy` at a random yaw, its centre `lift` above the ground, at rest; its target drawn beyond it."""
        box_yaw = rng.uniform(-np.pi, np.pi)
        q, v = self.qpos_adr, self.qvel_adr
        data.qpos[q:q + 3] = (box_xy[0], box_xy[1], float(self.arena.height_at(box_xy)) + lift)
        data.qpos[q + 3:q + 7] = quat_mul(self._tilt, np.array([np.cos(box_yaw / 2), 0.0, 0.0, np.sin(box_yaw / 2)]))
        data.qvel[v:v + 6] = 0.0
        self._draw(i, root_xy, box_xy, rng)

    def _draw(self, i: int, root_xy: np.ndarray, box_xy: np.ndarray, rng: np.random.Generator) -> None:
        away = box_xy - root_xy
        self.target[i] = box_xy + polar(rng, self.config.box_target_distance, np.arctan2(away[1], away[0]), np.pi / 4)

    def capture(self, i: int, data) -> None:
        q, v = self.qpos_adr, self.qvel_adr
        self.box[i] = data.qpos[q:q + 3]
        self.box_vel[i] = data.qvel[v:v + 2]  # a free joint's linear velocity is in the world frame
        xmat = data.xmat[self.body]
        self.box_yaw[i] = np.arctan2(xmat[3], xmat[0])  # its x axis's heading (tipping is rare and harmless here)

    def rewards(self, root_xy: np.ndarray, vel_xy: np.ndarray, yaw: np.ndarray, rng: np.random.Generator):
        box_xy = self.box[:, :2]
        to_box = box_xy - root_xy
        d_box = np.linalg.norm(to_box, axis=1)
        toward_box = np.einsum("bi,bi->b", vel_xy, to_box) / np.maximum(d_box, 1e-6)
        approach = np.where(d_box > APPROACH_M, np.exp(-2.0 * (toward_box - 1.0) ** 2), 1.0)
        near = np.exp(-2.0 * np.maximum(d_box - NEAR_M, 0.0) ** 2)
        to_target = self.target - box_xy
        d_target = np.linalg.norm(to_target, axis=1)
        push = np.clip(np.einsum("bi,bi->b", self.box_vel, to_target) / np.maximum(d_target, 1e-6), 0.0, PUSH_SPEED) / PUSH_SPEED
        rewards = 0.2 * approach + 0.2 * near + 0.3 * push + 0.3 * np.exp(-d_target)
        reached = d_target < self.config.success_radius
        rewards[reached] += self.config.success_bonus
        for i in np.flatnonzero(reached):
            self._draw(i, root_xy[i], box_xy[i], rng)
        return rewards, reached

    def features(self, root_xy: np.ndarray, vel_xy: np.ndarray, yaw: np.ndarray, out: np.ndarray) -> np.ndarray:
        box_xy = self.box[:, :2]
        rel = to_heading_frame(box_xy - root_xy, yaw)
        out[:, 0:2] = rel
        out[:, 2] = np.linalg.norm(rel, axis=1)
        relative_yaw = wrap_angle(self.box_yaw - yaw)
        out[:, 3] = np.cos(relative_yaw)
        out[:, 4] = np.sin(relative_yaw)
        out[:, 5:7] = to_heading_frame(self.box_vel, yaw)
        out[:, 7:9] = to_heading_frame(self.target - root_xy, yaw)
        out[:, 9:11] = to_heading_frame(self.target - box_xy, yaw)
        return out

    def first_direction(self, i: int) -> np.ndarray:
        """The unit xy direction of env i's push, box to target (the slope's figures split on it)."""
        d = self.target[i] - self.box[i, :2]
        return d / max(float(np.linalg.norm(d)), 1e-9)

    def marker(self, i: int) -> np.ndarray:
        return np.array([self.target[i, 0], self.target[i, 1], float(self.arena.height_at(self.target[i]))])
