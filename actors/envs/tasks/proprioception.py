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

from actors.character.features import FeatureExtractor, obs_dim
from actors.character.humanoid3d import HUMANOID3D


def proprio_dim(character=HUMANOID3D) -> int:
    """The observation minus the phase (its last entry), reference roots excluded."""
    return obs_dim(character) - 1


PROPRIO_DIM = proprio_dim(HUMANOID3D)  # 196


def proprioception_from_observation(observation: np.ndarray, character=HUMANOID3D) -> np.ndarray:
    """s_t from an imitation observation (..., obs_dim) of any reference width: its first
    `proprio_dim` entries (196 for humanoid3d; a view)."""
    observation = np.asarray(observation)
    if observation.shape[-1] < obs_dim(character):
        raise ValueError(f"proprioception: an observation has at least {obs_dim(character)} entries, got {observation.shape[-1]}")
    return observation[..., :proprio_dim(character)]


class Proprioception:
    """s_t straight from a MuJoCo state (after `update_kinematics`), for envs without a reference."""

    def __init__(self, features: FeatureExtractor):
        self.features = features
        self._obs = np.zeros((1, features.obs_dim))
        self.width = features.obs_dim - 1

    def __call__(self, data: mujoco.MjData, out: np.ndarray | None = None) -> np.ndarray:
        """(196,) float32 proprioception of `data`; into `out` when given."""
        obs = self.features.observation(data, 0.0, self._obs)
        if out is None:
            return obs[:self.width].astype(np.float32)
        out[...] = obs[:self.width]
        return out


def proprioception(features: FeatureExtractor, data: mujoco.MjData) -> np.ndarray:
    """(196,) float32 s_t of `data` (one-off; `Proprioception` keeps its buffer between calls)."""
    return Proprioception(features)(data)
