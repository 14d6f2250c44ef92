"""Rollouts of one window's policy: what the next window starts from and what the fit scores.

Each episode starts at the window's first frame (the first window from the reference, FSI;
later windows from one of the previous window's hand-over states) and runs the policy to the
window's control end t_n. Recorded per episode: the observation at the start (s(t_{n-1}) of
eq. 15), the observation at t_n (s(t_n)), and there the full simulator state (qpos, qvel) and
the env's state vector, which start the next window. Episode 0 takes the policy's mean
actions; the others sample it (seeded), so that a first window, whose starts are all the
same, still hands over a spread of states.

An episode that falls before t_n ends there; it is kept with `reached` False (the fit uses
the episodes that reached t_n when there are any).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from actors.character.features import update_kinematics
from actors.envs.imitation_env import ImitationEnv
from learner.atomic_io import atomic_output

FIELDS = ("start_obs", "end_obs", "states", "qpos", "qvel", "reached", "steps")


@dataclass
class WindowRollouts:
    start_obs: np.ndarray  # (n, obs_dim) at the window's first frame
    end_obs: np.ndarray  # (n, obs_dim) at the control end (or the last step before a fall)
    states: np.ndarray  # (n, state_dim) env state vectors there
    qpos: np.ndarray  # (n, nq)
    qvel: np.ndarray  # (n, nv)
    reached: np.ndarray  # (n,) bool: the episode reached the control end standing
    steps: np.ndarray  # (n,) control steps taken

    def save(self, path: Path) -> Path:
        with atomic_output(path) as tmp, open(tmp, "wb") as f:
            np.savez(f, **{k: getattr(self, k) for k in FIELDS})
        return Path(path)

    @classmethod
    def load(cls, path: Path) -> "WindowRollouts":
        with np.load(path) as f:
            return cls(**{k: f[k] for k in FIELDS})

    def handover(self) -> "WindowRollouts":
        """The episodes that reached the control end (all of them when none did)."""
        keep = self.reached if self.reached.any() else np.ones_like(self.reached)
        return WindowRollouts(**{k: getattr(self, k)[keep] for k in FIELDS})

    @property
    def mean_root_xy(self) -> np.ndarray:
        return self.qpos[:, :2].mean(axis=0)


def start_episode(env: ImitationEnv, seed: int, handover: WindowRollouts | None, k: int) -> np.ndarray:
    """Reset at the window's first frame: from the reference (no hand-over) or from the
    previous window's k-th hand-over state, its full qpos/qvel (the horizontal position too,
    which the state vector leaves to the reference root). Returns the first observation."""
    obs, _ = env.reset(seed=seed, options={"init": "fsi"})
    if handover is None:
        return obs
    i = k % len(handover.qpos)
    env.data.qpos[:] = handover.qpos[i]
    env.data.qvel[:] = handover.qvel[i]
    update_kinematics(env.model, env.data)
    env.root_sync.reset(0, env.data.qpos[:2], env.row)
    out = np.empty(env.obs_dim, np.float32)
    return env.observation_into(out)


def roll_window(policy, env: ImitationEnv, control_steps: int, episodes: int, seed: int,
                handover: WindowRollouts | None = None) -> WindowRollouts:
    """`episodes` rollouts of `policy` from the window's first frame to `control_steps` later."""
    rng = np.random.default_rng(seed)
    rows = {k: [] for k in FIELDS}
    for k in range(episodes):
        obs = start_episode(env, seed + k, handover, k)
        rows["start_obs"].append(obs.copy())
        steps, fell = 0, False
        limit = min(control_steps, env.max_episode_steps)  # the window's reference ends there
        while steps < limit:
            action, _ = policy.act(obs[None], rng, deterministic=(k == 0))
            next_obs, _, terminated, truncated, _ = env.step(action[0])
            if terminated:  # a fall: the observation before it is kept, the episode not handed over
                fell = True
                break
            obs, steps = next_obs, steps + 1
            if truncated:
                break
        rows["end_obs"].append(obs.copy())
        rows["states"].append(env.state_vector())
        rows["qpos"].append(env.data.qpos.copy())
        rows["qvel"].append(env.data.qvel.copy())
        rows["reached"].append(not fell and steps >= limit)
        rows["steps"].append(steps)
    return WindowRollouts(**{k: np.asarray(v) for k, v in rows.items()})
