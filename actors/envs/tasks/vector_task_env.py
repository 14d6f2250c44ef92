"""M task envs in one process, stepped together (`actors/envs/vector_env.py`'s pattern).

Each control step: the action space turns the (M, A) actions into PD targets in one batched
call (for latent actions that is the frozen decoder on every env's proprioception), MuJoCo
steps each env, the features of all envs are computed in one pass, and the task scores them.
Observations are the 196 proprioceptive features (`FeatureExtractor`'s observation without
its phase; what the decoder sees) followed by the task's features in the heading frame. A
finished env is reset at once (auto-reset) and its episode is logged: return, length, fall,
whether and when the first target was reached, targets reached.

On a slope (`--env.slope`, `actors/arenas/slope.py`) three things change, all so that the frozen
decoder, which learnt on the flat, sees what it knows: its root-height feature is the height
above the ground under the root (not above z = 0), episodes start turned to a random heading
and set down on the incline (`slope_starts.py`), and the pelvis-height fall rule measures from
the ground too. The task policy also observes the grade in its heading frame (2 numbers after
the proprioception), and each episode logs the grade along its first task direction
(`grade_along`: +0.15 straight up a 15 % slope, -0.15 straight down), which `sfv task eval`
splits its figures by.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field

import mujoco
import numpy as np

from actors.character.features import FeatureExtractor
from actors.character.humanoid3d import HUMANOID3D
from actors.envs.simulator import MujocoSimulator
from actors.envs.tasks.action_spaces import make_action_space
from actors.envs.tasks.config import TaskEnvConfig
from actors.envs.tasks.floor_fall import FloorFall
from actors.envs.tasks.go_to import GoToTask
from actors.envs.tasks.geometry import to_heading_frame
from actors.envs.tasks.phased_push_box import PhasedPushBoxTask
from actors.envs.tasks.push_box import PushBoxTask
from actors.envs.tasks.slope_starts import set_down, turn_start
from actors.envs.tasks.starts import ClipStarts

TASK_CLASSES = {"go_to": GoToTask, "push_box": PushBoxTask, "push_box_phased": PhasedPushBoxTask}


@dataclass
class TaskEpisodeLog:
    """Finished episodes since the last `drain()`."""

    returns: list = field(default_factory=list)
    normalized_returns: list = field(default_factory=list)  # return / horizon steps: the mean reward per step of a full episode
    discounted_returns: list = field(default_factory=list)
    lengths: list = field(default_factory=list)
    fell: list = field(default_factory=list)
    successes: list = field(default_factory=list)  # reached at least one target
    first_success_s: list = field(default_factory=list)  # seconds to the first target (nan: none)
    targets_reached: list = field(default_factory=list)
    grade_along: list = field(default_factory=list)  # the ground's rise over run along the first task direction (0 on the flat)
    start_phase: list = field(default_factory=list)  # a phased task's phase at the start (-1 for the others)
    first_phase_done: list = field(default_factory=list)  # a phased task's first phase completed (the box reached; False for the others)

    def drain(self) -> dict[str, np.ndarray]:
        out = {k: np.asarray(v, np.float32) for k, v in self.__dict__.items()}
        out["fell"] = out["fell"].astype(bool)
        out["successes"] = out["successes"].astype(bool)
        for v in self.__dict__.values():
            v.clear()
        return out


class VectorTaskEnv:
    def __init__(self, config: TaskEnvConfig, num_envs: int, seed: int = 0, gamma: float = 0.95):
        task_class = TASK_CLASSES[config.task]
        self.config = config
        self.num_envs = m = num_envs
        self.gamma = gamma
        self.arena = task_class.arena_for(config)
        self.sloped = self.arena.grade > 0.0
        self.humanoid = HUMANOID3D.build(config.physics, self.arena)
        self.model = self.humanoid.model
        self.datas = [mujoco.MjData(self.model) for _ in range(m)]
        # A task that changes its props per episode (the phased push-box's box size and mass) gets a model per env.
        models = [copy.deepcopy(self.model) for _ in range(m)] if getattr(task_class, "per_env_models", False) else [self.model] * m
        self.sim = MujocoSimulator(models, self.datas, config.substeps)
        self.task = task_class(config, m, self.model)
        if hasattr(self.task, "bind_models"):
            self.task.bind_models(models)
        self.action_space = make_action_space(config)
        self.starts = ClipStarts(config.start_motion, config.physics, 1.0 / config.control_hz)
        self.features = FeatureExtractor(self.humanoid, m)
        self.fall = FloorFall(self.humanoid, self.arena if self.sloped else None)
        self._walker_geoms = np.flatnonzero(np.isin(self.model.geom_bodyid, self.humanoid.body_ids))
        self.substeps = config.substeps
        self.rng = np.random.default_rng(seed)
        self.proprio_dim = self.features.obs_dim - 1  # the observation without its phase (actors/envs/tasks/proprioception.py)
        self.ground_dim = 2 if self.sloped else 0  # the grade in the heading frame
        self.obs_dim = self.proprio_dim + self.ground_dim + self.task.obs_dim
        self.action_dim = self.action_space.action_dim
        self.obs = np.zeros((m, self.obs_dim), np.float32)
        self.final_obs = np.zeros_like(self.obs)
        self.rewards = np.zeros(m, np.float32)
        self.terminated = np.zeros(m, bool)
        self.truncated = np.zeros(m, bool)
        self.reached = np.zeros(m, bool)
        self._full = np.zeros((m, self.features.obs_dim))
        self._task_obs = np.zeros((m, self.task.obs_dim))
        self._targets = np.zeros((m, self.model.nu))
        self._fell = np.zeros(m, bool)
        self._diverged = np.zeros(m, bool)
        self._ret, self._disc, self._discount = np.zeros(m), np.zeros(m), np.ones(m)
        self._len = np.zeros(m, np.int64)
        self._hits = np.zeros(m, np.int64)
        self._first_hit = np.full(m, -1, np.int64)
        self._grade_along = np.zeros(m)
        self._phased = hasattr(self.task, "phase_reached")  # the phased push-box: its start phase and first phase logged
        self._start_phase = np.zeros(m, np.int64)
        self._first_phase_done = np.zeros(m, bool)
        self._max_steps = config.horizon_steps
        self._cap: int | None = None
        self._limit = np.full(m, self._max_steps, np.int64)  # each env's episode length
        self.episodes = TaskEpisodeLog()

    # ---------------------------------------------------------------- episodes
    @property
    def max_episode_steps(self) -> int:
        return self._max_steps

    @property
    def rows(self) -> np.ndarray:
        """Each env's control steps since its episode began: a task's "frame" (what the rollout
        worker ships for adaptive tuple sampling; tasks have no reference row)."""
        return self._len

    def set_horizon(self, seconds: float | None) -> None:
        """Cap episodes that start from now on (the driver's curriculum seam); None: the config's horizon."""
        self._cap = None if seconds is None else max(1, int(round(seconds * self.config.control_hz)))

    def terrain_levels(self) -> None:
        """No terrain curriculum on a task's flat arena (the rollout worker's seam: `VectorImitationEnv`'s levels)."""
        return None

    def reset(self) -> np.ndarray:
        for i in range(self.num_envs):
            self._reset_env(i)
        self._observe()
        return self.obs

    def _reset_env(self, i: int) -> None:
        data = self.sim.reset(i)
        qpos, qvel = self.starts.take(self.rng)
        character = self.humanoid.character  # its own coordinates come first (props follow them)
        data.qpos[:character.nq], data.qvel[:character.nv] = qpos, qvel
        if self.sloped:
            turn_start(data.qpos, data.qvel, self.rng.uniform(-np.pi, np.pi))
            set_down(self.arena, self.sim.models[i], data, self._walker_geoms)
        self.sim.forward(i)
        yaw = float(np.arctan2(data.xmat[1, 3], data.xmat[1, 0]))
        self.task.reset(i, data.qpos[:2].copy(), yaw, self.rng, data)
        mujoco.mj_forward(self.sim.models[i], data)
        data.ctrl[:] = data.actuator_length  # hold the start pose: no jerk in the first substeps
        self.features.capture(i, data)
        self.task.capture(i, data)
        self._grade_along[i] = float(self.arena.gradient @ self.task.first_direction(i))
        self._start_phase[i] = self.task.phase[i] if self._phased else -1
        self._first_phase_done[i] = False
        self._ret[i] = self._disc[i] = 0.0
        self._discount[i] = 1.0
        self._len[i] = self._hits[i] = 0
        self._first_hit[i] = -1
        self._limit[i] = self._max_steps if self._cap is None else min(self._cap, self._max_steps)

    # -------------------------------------------------------------------- step
    def step(self, actions: np.ndarray):
        """Step every env; returns views of (obs, rewards, terminated, truncated, final_obs)
        with `final_obs[i]` the true successor of a reset env (for bootstrapping)."""
        targets = self.action_space.targets(actions, self.obs[:, :self.proprio_dim], self._targets)
        self.sim.step(targets, self._fell, self._diverged, self.fall, (self.features.capture, self.task.capture))
        root_xy, vel_xy, yaw = self._planar()
        rewards, reached = self.task.rewards(root_xy, vel_xy, yaw, self.rng)
        rewards[self._fell | self._diverged] = 0.0  # the falling step earns nothing
        self.rewards[:] = rewards
        self.reached[:] = reached
        self._observe()
        self.final_obs[:] = self.obs
        self._book(rewards, reached)
        self.terminated[:] = self._fell | self._diverged
        self.truncated[:] = ~self.terminated & (self._len >= self._limit)
        ended = np.flatnonzero(self.terminated | self.truncated)
        for i in ended:
            self._record(i)
            self._reset_env(i)
        if len(ended):
            self._observe()
        return self.obs, self.rewards, self.terminated, self.truncated, self.final_obs

    def planar_state(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(root xy (M, 2), centre-of-mass velocity xy (M, 2), yaw (M,)) of every env now."""
        return self._planar()

    def refresh_observations(self) -> np.ndarray:
        """The observations again, after a caller changed a task's targets (the heatmap's placement)."""
        self._observe()
        return self.obs

    def _planar(self):
        f = self.features
        yaw = np.arctan2(f.root_xmat[:, 3], f.root_xmat[:, 0])
        return f.pos[:, 0, :2], f.com_vel[:, :2], yaw

    def _observe(self) -> None:
        f = self.features
        f.observations(0.0, self._full, f.heading())
        root_xy, vel_xy, yaw = self._planar()
        p = self.proprio_dim
        if self.sloped:  # root height above the ground under it; the grade as the character faces it
            self._full[:, 0] -= self.arena.height_at(root_xy)
            self.obs[:, p:p + 2] = to_heading_frame(np.broadcast_to(self.arena.gradient, root_xy.shape), yaw)
        self.obs[:, :p] = self._full[:, :p]
        self.obs[:, p + self.ground_dim:] = self.task.features(root_xy, vel_xy, yaw, self._task_obs)

    def _book(self, rewards: np.ndarray, reached: np.ndarray) -> None:
        self._ret += rewards
        self._disc += self._discount * rewards
        self._discount *= self.gamma
        self._len += 1
        self._hits += reached
        first = reached & (self._first_hit < 0)
        self._first_hit[first] = self._len[first]
        if self._phased:
            self._first_phase_done |= self.task.phase_reached

    def _record(self, i: int) -> None:
        log = self.episodes
        log.returns.append(self._ret[i])
        log.normalized_returns.append(self._ret[i] / self._max_steps)
        log.discounted_returns.append(self._disc[i])
        log.lengths.append(self._len[i])
        log.fell.append(bool(self._fell[i] or self._diverged[i]))
        log.successes.append(self._hits[i] > 0)
        log.first_success_s.append(self._first_hit[i] / self.config.control_hz if self._first_hit[i] >= 0 else np.nan)
        log.targets_reached.append(self._hits[i])
        log.grade_along.append(self._grade_along[i])
        log.start_phase.append(self._start_phase[i])
        log.first_phase_done.append(bool(self._first_phase_done[i]))
