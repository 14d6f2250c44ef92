"""Deterministic policy rollouts, step by step, and their recording as a ReferenceMotion (in the
pose space of the env's character: a robot's is written as a robot motion file, `sfv export`).

`episode_steps` is a generator: it yields once after reset and once after every control
step, so a caller can look at (render, record) or act on (push) `env.data` in between.
Episode k resets with seed `seed + k` and the given init (FSI or RSI, or a fixed start phase) and ends where the env's
own termination ends it. `sfv eval` scores differently on purpose: episodes at evenly spaced
phases and the strict fall rule whatever the training's termination (`services/training/evaluation.py`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator

import numpy as np

from actors.envs.imitation_env import ImitationEnv
from actors.motion.reference_motion import ReferenceMotion


@dataclass
class StepProgress:
    step: int  # control steps taken so far in this episode
    max_steps: int  # steps this episode may run (the env's horizon, capped by --seconds)
    reward: float  # reward of the last step (0 after reset)
    total_reward: float
    normalized_return: float  # total so far over the most the episode could earn
    terminated: bool  # fell (or diverged)
    done: bool


def start_options(init: str, phase: float | None) -> dict:
    """The reset options of an episode started by `init`, or at `phase` of the clip when given."""
    if phase is None:
        return {"init": init}
    if not 0.0 <= phase <= 1.0:
        raise ValueError(f"phase must be in [0, 1], got {phase}")
    return {"init": "rsi", "phase": float(phase)}


def episode_limit(env: ImitationEnv, seconds: float | None) -> int:
    limit = env.max_episode_steps
    if seconds is not None:
        limit = min(limit, max(1, int(round(seconds * env.config.control_hz))))
    return limit


def episode_steps(policy, env: ImitationEnv, seed: int, init: str, seconds: float | None = None,
                  phase: float | None = None) -> Iterator[StepProgress]:
    """`phase` (0-1) starts the episode at that phase of the clip whatever `init` says."""
    obs, _ = env.reset(seed=seed, options=start_options(init, phase))
    obs_row = np.empty((1, env.observation_space.shape[0]), np.float32)
    obs_row[0] = obs
    limit = episode_limit(env, seconds)
    best = env.max_episode_return(limit)  # = max_reward x limit without a scene
    progress = StepProgress(0, limit, 0.0, 0.0, 0.0, False, False)
    yield progress
    for step in range(1, limit + 1):
        action, _ = policy.act(obs_row, deterministic=True)
        obs, reward, terminated, truncated, _ = env.step(action[0])
        obs_row[0] = obs
        progress.step, progress.reward = step, float(reward)
        progress.total_reward += float(reward)
        progress.normalized_return = progress.total_reward / best
        progress.terminated = bool(terminated)
        progress.done = bool(terminated or truncated or step == limit)
        yield progress
        if progress.done:
            return


def record_episode(policy, env: ImitationEnv, seed: int, init: str, seconds: float | None, name: str,
                   phase: float | None = None) -> tuple[ReferenceMotion, StepProgress]:
    """The simulated character's root and joint rotations at every control step (reset included)."""
    root_pos = root_rot = joint_rot = None
    count = 0
    for progress in episode_steps(policy, env, seed, init, seconds, phase):
        if root_pos is None:  # after reset, when the episode's length is known
            rows = progress.max_steps + 1
            root_pos, root_rot, joint_rot = np.empty((rows, 3)), np.empty((rows, 4)), np.empty((rows, env.layout.num_joints, 4))
        qpos = env.data.qpos
        if not np.isfinite(qpos).all():
            break  # the simulation diverged on this step (the env ends the episode as a fall)
        root_pos[count] = qpos[0:3]
        root_rot[count] = qpos[3:7]
        env.layout.joint_quats_from_qpos(qpos, joint_rot[count])
        count += 1
    frame_times = np.arange(count) / env.config.control_hz
    motion = ReferenceMotion(name, frame_times, root_pos[:count], root_rot[:count], joint_rot[:count], loop=False,
                             character=env.humanoid.character.name)
    return motion, progress
