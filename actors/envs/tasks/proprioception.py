"""Proprioception s_t: what the motor module's decoder sees (004 §3.3, contract of issue 16).

004 §3.3: the decoder "only directly receives egocentric humanoid proprioceptive information",
so that it is reusable in any scene by a task policy that has no reference motion. Here s_t is
the character part of the imitation observation (`actors/character/features.py`) without the phase and
without the reference-root entries: the first `PROPRIO_DIM` = 196 entries of
`FeatureExtractor.observation(...)`, i.e. the root height (1), then for the 15 links their
positions relative to the root (45), rotations (60, w >= 0), linear (45) and angular (45)
velocities, all in the character's heading frame.

Deviation from 004: its proprioception also holds joint angles, velocities and touch sensors;
the link features here carry the same pose and motion (joint angles are functions of the link
rotations), and the task-policy engineer's env computes them with the same extractor.
"""
from __future__ import annotations

import mujoco
import numpy as np

from actors.character.features import OBS_DIM, FeatureExtractor

PROPRIO_DIM = OBS_DIM - 1  # 196: the observation minus the phase (its last entry), reference roots excluded


def proprioception_from_observation(observation: np.ndarray) -> np.ndarray:
    """s_t from an imitation observation (..., obs_dim) of any reference width: its first 196 entries (a view)."""
    observation = np.asarray(observation)
    if observation.shape[-1] < OBS_DIM:
        raise ValueError(f"proprioception: an observation has at least {OBS_DIM} entries, got {observation.shape[-1]}")
    return observation[..., :PROPRIO_DIM]


class Proprioception:
    """s_t straight from a MuJoCo state (after `update_kinematics`), for envs without a reference."""

    def __init__(self, features: FeatureExtractor):
        self.features = features
        self._obs = np.zeros((1, OBS_DIM))

    def __call__(self, data: mujoco.MjData, out: np.ndarray | None = None) -> np.ndarray:
        """(196,) float32 proprioception of `data`; into `out` when given."""
        obs = self.features.observation(data, 0.0, self._obs)
        if out is None:
            return obs[:PROPRIO_DIM].astype(np.float32)
        out[...] = obs[:PROPRIO_DIM]
        return out


def proprioception(features: FeatureExtractor, data: mujoco.MjData) -> np.ndarray:
    """(196,) float32 s_t of `data` (one-off; `Proprioception` keeps its buffer between calls)."""
    return Proprioception(features)(data)
