"""The push-box in 004's phased form: go to the box, then push it to its target, a sparse reward per phase.

NPMP 004 (§3.4, Fig. 8) structures its object tasks as phases with a sparse reward each (GOTO,
LIFT, CARRY, PUTDOWN), varies the box per episode, and starts episodes in every phase (its Fig. 8B
ablation: starting only in the first phase learns much less). With locomotion experts there is no
grasp, so the phases here are two:

    GOTO  the walker's root within REACH_M of the box's centre  -> success_bonus, phase PUSH
    PUSH  the box within success_radius of its target, slower   -> success_bonus, a new target
          than REST_SPEED (it stops there, not slides past)        beyond the box (phase stays)

Nothing else is paid except the progress toward the phase's goal, `box_shaping` x (d - d') with d
the distance to it before the step and d' after (the walker to within REACH_M of the box, then the
box to its target): metres gained per step. The potential-based form (Ng et al. 1999, gamma Phi' -
Phi with Phi = -d) would leave the sparse task's optimum exactly unchanged, but with the tasks'
gamma of .95-.99 it pays (1 - gamma) d' per step for merely being far (measured with z = 0
throughout: a return of 80 with no box delivered), so the plain difference is used: it telescopes
to the distance gained over an episode. The step a phase changes earns no progress (the distance
restarts with the new goal).

Per episode (`reset`):
- the box's half sizes are the arena's scaled by U(box_size_scale) per axis, and its mass
  U(box_mass) kg, written into the env's own MjModel (geom size, bounding radius and box, body
  mass and inertia), so one batch pushes boxes of every size and weight;
- with probability `push_start_share` the episode starts in PUSH, the box just ahead of the walker
  (its centre U(PUSH_START_GAP_M) m beyond its larger horizontal half size, within +-20 deg of the
  walker's heading; 0.55-0.75 m for the arena's box), otherwise in GOTO, the box U(box_distance) m
  ahead within +-45 deg (the plain push-box's start).

Features (17, heading frame): the plain push-box's 11, the phase one-hot (2), the box's half
sizes (3, m) and its mass (kg / 10).
"""
from __future__ import annotations

import mujoco
import numpy as np

from actors.arenas.push_box import BOX_GEOM
from actors.envs.tasks.geometry import polar
from actors.envs.tasks.push_box import PushBoxTask

REACH_M = 0.7  # the walker's root this near the box's centre: the box is within arm's reach (half sizes 0.2-0.3 m)
PUSH_START_GAP_M = (0.3, 0.5)  # a push start: the box's centre this far beyond its larger horizontal half size
REST_SPEED = 0.3  # m/s: a box delivered stops at its target (a box knocked through the circle by a running start does not count)
GOTO, PUSH = 0, 1


class PhasedPushBoxTask(PushBoxTask):
    obs_dim = PushBoxTask.obs_dim + 6
    per_env_models = True  # each env's box has its own size and mass

    def __init__(self, config, num_envs: int, model=None):
        super().__init__(config, num_envs, model)
        self.models = None  # each env's MjModel, bound by the env (`bind_models`)
        self.phase = np.zeros(num_envs, np.int64)
        self.half_size = np.tile(np.asarray(self.arena.half_size, float), (num_envs, 1))
        self.mass = np.full(num_envs, float(self.arena.mass))
        self.phase_reached = np.zeros(num_envs, bool)  # this step: the walker reached the box (GOTO done)
        self._distance = np.zeros(num_envs)  # each env's distance to its phase's goal after the last step
        if model is not None:
            self.geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, BOX_GEOM)

    def bind_models(self, models) -> None:
        self.models = list(models)
        self._scratch = mujoco.MjData(self.models[0])  # mj_setConst's workspace (every env's model has the same layout)

    def reset(self, i: int, root_xy: np.ndarray, yaw: float, rng: np.random.Generator, data=None) -> None:
        c = self.config
        self._resize(i, rng)
        pushing = rng.uniform() < c.push_start_share
        near = tuple(gap + float(self.half_size[i, :2].max()) for gap in PUSH_START_GAP_M)
        box_xy = root_xy + (polar(rng, near, yaw, np.radians(20.0)) if pushing else polar(rng, c.box_distance, yaw, np.pi / 4))
        self._place_box(i, root_xy, box_xy, self.half_size[i, 2] / np.cos(np.arctan(self.arena.grade)), rng, data)
        self.phase[i] = PUSH if pushing else GOTO
        self.box[i, :2] = box_xy
        self._distance[i] = self._goal_distances(root_xy[None], self.phase[i:i + 1], self.box[i:i + 1, :2], self.target[i:i + 1])[0]

    def _resize(self, i: int, rng: np.random.Generator) -> None:
        """A new box for env i: half sizes and mass drawn, written into its model with a solid box's inertia."""
        c = self.config
        half = np.asarray(self.arena.half_size, float) * rng.uniform(*c.box_size_scale, size=3)
        mass = rng.uniform(*c.box_mass)
        self.half_size[i], self.mass[i] = half, mass
        if self.models is None:
            return
        model = self.models[i]
        model.geom_size[self.geom] = half
        model.geom_rbound[self.geom] = float(np.linalg.norm(half))
        model.geom_aabb[self.geom, 3:] = half  # the box's bounding box about its own centre (midphase)
        model.body_mass[self.body] = mass
        a, b, h = 2.0 * half
        model.body_inertia[self.body] = mass / 12.0 * np.array([b * b + h * h, a * a + h * h, a * a + b * b])
        # The constants MuJoCo derives from masses and sizes (the constraint solver's inverse weights, ...):
        # left at the compiled box's, a 2-10 kg box of another size blew the simulation up within 20 s of
        # random latent actions (box at 3e7 m), where the compiled 5 kg box did not.
        mujoco.mj_setConst(model, self._scratch)

    @staticmethod
    def _goal_distances(root_xy, phase, box_xy, target) -> np.ndarray:
        """Each env's distance to its phase's goal: the walker to REACH_M of the box, the box to its target."""
        walker = np.maximum(np.linalg.norm(box_xy - root_xy, axis=1) - REACH_M, 0.0)
        return np.where(phase == GOTO, walker, np.linalg.norm(target - box_xy, axis=1))

    def rewards(self, root_xy: np.ndarray, vel_xy: np.ndarray, yaw: np.ndarray, rng: np.random.Generator):
        c = self.config
        box_xy = self.box[:, :2]
        walker_at_box = np.linalg.norm(box_xy - root_xy, axis=1) <= REACH_M
        self.phase_reached[:] = (self.phase == GOTO) & walker_at_box
        delivered = ((self.phase == PUSH) & (np.linalg.norm(self.target - box_xy, axis=1) < c.success_radius)
                     & (np.linalg.norm(self.box_vel, axis=1) < REST_SPEED))
        distance = self._goal_distances(root_xy, self.phase, box_xy, self.target)
        rewards = c.box_shaping * (self._distance - distance)
        changed = self.phase_reached | delivered
        rewards[changed] = c.success_bonus  # the goal changes: no progress is paid across it
        self.phase[self.phase_reached] = PUSH
        for i in np.flatnonzero(delivered):
            self._draw(i, root_xy[i], box_xy[i], rng)
        self._distance[:] = distance
        if changed.any():  # measured from the new goal on
            self._distance[changed] = self._goal_distances(root_xy, self.phase, box_xy, self.target)[changed]
        return rewards, delivered

    def features(self, root_xy: np.ndarray, vel_xy: np.ndarray, yaw: np.ndarray, out: np.ndarray) -> np.ndarray:
        base = PushBoxTask.obs_dim
        super().features(root_xy, vel_xy, yaw, out[:, :base])
        out[:, base] = self.phase == GOTO
        out[:, base + 1] = self.phase == PUSH
        out[:, base + 2:base + 5] = self.half_size
        out[:, base + 5] = self.mass / 10.0
        return out
