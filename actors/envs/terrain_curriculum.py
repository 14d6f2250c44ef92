"""The terrain curriculum: each env climbs or descends difficulty levels by its own episodes.

The legged-locomotion terrain curriculum (Rudin et al. 2022): an env whose character got
through its episode moves to harder ground, one that fell moves back. Here an episode of at
least UP_AFTER_S seconds without a fall moves the env up a level (a tenth of the top
difficulty), a fall moves it down one; every env starts on flat ground (level 0), or at
`start_level` when a resumed training passes the level its checkpoint recorded. The mean
difficulty of the finished episodes is logged per iteration (`episode_terrain_difficulty`).
"""
from __future__ import annotations

import numpy as np

LEVELS = 10
UP_AFTER_S = 2.0  # shorter episodes (the episode-length curriculum's first caps) say little about the ground


class TerrainCurriculum:
    def __init__(self, num_envs: int, top: float, control_hz: float, start_level: int = 0):
        if not 0 <= start_level <= LEVELS:
            raise ValueError(f"a terrain curriculum's start level must lie in [0, {LEVELS}], got {start_level}")
        self.top = float(top)
        self.up_after_steps = int(round(UP_AFTER_S * control_hz))
        self.levels = np.full(num_envs, start_level, dtype=np.int64)

    def difficulty(self, i: int) -> float:
        return float(self.top * self.levels[i] / LEVELS)

    def update(self, i: int, fell: bool, steps: int) -> float:
        """Env i's difficulty for its next episode, after one that ended (`fell`, `steps` long)."""
        if fell:
            self.levels[i] = max(self.levels[i] - 1, 0)
        elif steps >= self.up_after_steps:
            self.levels[i] = min(self.levels[i] + 1, LEVELS)
        return self.difficulty(i)
