"""The three things the env suite times, each stepping at the configured physics and
control rates in this process:

* `RawPhysics`: MuJoCo alone, the config's character open-loop (fixed PD targets), `substeps` physics
  steps per control step, reset when the root drops or at the horizon. No observation,
  no reward, no policy: the upper bound on control steps/s for this model on one core.
* `EnvStepper`: `ImitationEnv.step` with random actions (observation + reward + fall
  check) and auto-reset, i.e. what the gymnasium env costs on top of the physics.
* `WorkerStepper`: a `RolloutWorker` with M envs and the paper's 1024-512 policy in the
  loop (batched numpy inference), i.e. what a training process actually delivers.

Each exposes `chunk() -> control steps done`, sized to take a few milliseconds at least,
for `measure.rate_for`.
"""
from __future__ import annotations

import mujoco
import numpy as np

from actors.character.features import OBS_DIM
from actors.character.characters import character_named
from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.motion.reference_motion import ReferenceMotion
from actors.rollout.worker import RolloutWorker, WorkerSpec

FALLEN_ROOT_HEIGHT = 0.5  # m; the standing root is at 0.88


class RawPhysics:
    def __init__(self, env_config: EnvConfig, steps_per_chunk: int = 30):
        self.model = character_named(env_config.character).build(env_config.physics).model
        self.data = mujoco.MjData(self.model)
        self.substeps = env_config.substeps
        self.horizon = max(1, round(env_config.horizon_s * env_config.control_hz))
        self.steps_per_chunk = steps_per_chunk
        self.resets = 0
        self._since_reset = 0
        self._reset()

    def _reset(self) -> None:
        # qpos0 stands the character upright; ctrl 0 holds every joint at its rest angle.
        mujoco.mj_resetData(self.model, self.data)
        self._since_reset = 0

    def chunk(self) -> int:
        model, data, substeps = self.model, self.data, self.substeps
        for _ in range(self.steps_per_chunk):
            mujoco.mj_step(model, data, nstep=substeps)
            self._since_reset += 1
            if data.qpos[2] < FALLEN_ROOT_HEIGHT or self._since_reset >= self.horizon:
                self.resets += 1
                self._reset()
        return self.steps_per_chunk


class EnvStepper:
    """One ImitationEnv, random actions ~ N(0, action_noise^2) clipped to the action box."""

    def __init__(self, motion: ReferenceMotion, env_config: EnvConfig, action_noise: float, seed: int = 0,
                 steps_per_chunk: int = 30):
        self.env = ImitationEnv(motion, env_config)
        self.rng = np.random.default_rng(seed)
        self.action_noise = action_noise
        self.steps_per_chunk = steps_per_chunk
        self.actions = np.zeros((steps_per_chunk, self.env.action_space.shape[0]), np.float32)
        self.resets = 0
        self.env.reset(seed=seed)

    def chunk(self) -> int:
        env = self.env
        self.rng.standard_normal(out=self.actions, dtype=np.float32)
        self.actions *= self.action_noise
        np.clip(self.actions, -1.0, 1.0, out=self.actions)
        for action in self.actions:
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                self.resets += 1
                env.reset()
        return self.steps_per_chunk


class WorkerStepper:
    """A RolloutWorker (RSI starts, no ASI server) sampling with fixed policy weights."""

    def __init__(self, motion: ReferenceMotion, env_config: EnvConfig, num_envs: int, policy_weights: dict,
                 seed: int = 0, steps_per_sample: int = 8):
        self.worker = RolloutWorker(WorkerSpec(motion, env_config, num_envs, "rsi", seed), 0)
        self.weights = policy_weights
        self.num_envs = num_envs
        self.steps_per_sample = steps_per_sample
        self.episodes = 0

    def chunk(self) -> int:
        batch = self.worker.sample(self.weights, 0, self.steps_per_sample)
        self.episodes += len(batch["episode_lengths"])
        return self.steps_per_sample * self.num_envs


def fresh_policy_weights(action_dim: int, hidden: tuple[int, ...] = (1024, 512), seed: int = 0, obs_dim: int = OBS_DIM) -> dict:
    """The weights of a freshly initialised PPO policy of the paper's size."""
    from learner.config import PPOConfig
    from learner.ppo import PPOLearner

    learner = PPOLearner(obs_dim, action_dim, PPOConfig(policy_hidden=hidden, value_hidden=hidden, seed=seed))
    return learner.policy_weights()
