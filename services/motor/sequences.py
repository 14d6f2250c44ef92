"""Windows of consecutive steps for training the motor module through z_{t-1} -> z_t (004 §3.3).

The dataset's rows of one episode are consecutive and in step order (`services/motor/dataset.py`),
so a window of W steps starting at row i is valid when rows i and i + W - 1 belong to the same
(clip, episode). Whole episodes go either to training or to validation (a fraction, drawn once
from the seed), so validation windows never overlap training ones.
"""
from __future__ import annotations

import numpy as np

from learner.errors import SfvError


def episode_keys(clip: np.ndarray, episode: np.ndarray) -> np.ndarray:
    return clip.astype(np.int64) * (1 << 32) + episode.astype(np.int64)


def window_starts(keys: np.ndarray, window: int) -> np.ndarray:
    """Rows i where rows i .. i + window - 1 are one episode's."""
    if len(keys) < window:
        return np.zeros(0, dtype=np.int64)
    return np.flatnonzero(keys[: len(keys) - window + 1] == keys[window - 1:])


class WindowSampler:
    def __init__(self, clip: np.ndarray, episode: np.ndarray, window: int, validation_fraction: float, seed: int):
        keys = episode_keys(clip, episode)
        starts = window_starts(keys, window)
        if not len(starts):
            raise SfvError(f"motor dataset: no episode has {window} consecutive steps (shorten the window)")
        rng = np.random.default_rng(seed)
        unique = np.unique(keys)
        held = rng.random(len(unique)) < validation_fraction
        validation = np.isin(keys[starts], unique[held])
        self.train_starts, self.validation_starts = starts[~validation], starts[validation]
        if not len(self.train_starts):
            raise SfvError("motor dataset: every episode went to validation (lower the validation fraction)")
        self.offsets = np.arange(window)

    def rows(self, starts: np.ndarray) -> np.ndarray:
        """(B, W) row indices of the windows starting at `starts`."""
        return starts[:, None] + self.offsets

    def sample(self, rng: np.random.Generator, batch: int) -> np.ndarray:
        return self.rows(rng.choice(self.train_starts, size=batch))
