"""Re-synchronising the reference's horizontal root with the character's, once per cycle.

DeepMimic (`SceneImitate::SyncKinCharNewCycle`, `--sync_char_root_pos true` for every
humanoid3d clip) moves the kinematic reference's root to the simulated character's (x, y on
the ground) whenever a looped clip starts a new cycle. Within a cycle, drift costs the root
term; across cycles it does not accumulate, so a character that lags 30 cm after the first
step is not scored against a reference that is metres ahead ten cycles later. The reference
table stays shared and read-only: each env keeps an offset added to the reference row's
world positions (root and centre of mass) as it is read.
"""
from __future__ import annotations

import numpy as np

from actors.character.features import RewardFeatures


class RootSync:
    def __init__(self, track, batch: int, enabled: bool = True):
        self.enabled = enabled and track.motion.loop
        # A row starts a new cycle where the phase wraps (exact also for clips whose cycle is
        # not a whole number of control steps, e.g. the 52.5-step backflip).
        self.cycle_start = np.zeros(track.rows, dtype=bool)
        self.cycle_start[1:] = track.phase[1:] < track.phase[:-1]
        self.root_xy = track.qpos[:, :2]
        self.offset = np.zeros((batch, 2))
        self._new_cycle = np.zeros(batch, dtype=bool)

    def reset(self, i: int, sim_xy: np.ndarray, row: int) -> None:
        """Env i starts an episode at table row `row` with its root at `sim_xy`."""
        np.subtract(sim_xy, self.root_xy[row], out=self.offset[i])

    def apply(self, rows: np.ndarray, sim_xy: np.ndarray, ref: RewardFeatures) -> None:
        """After a step to `rows` (B,): re-sync the envs that entered a new cycle, then shift
        the gathered reference rows `ref` by each env's offset."""
        if not self.enabled:
            return
        np.take(self.cycle_start, rows, out=self._new_cycle)
        if self._new_cycle.any():  # a few times per cycle across the batch
            idx = np.flatnonzero(self._new_cycle)
            self.offset[idx] = sim_xy[idx] - self.root_xy[rows[idx]]
        ref.root_xy += self.offset
        ref.com_xy += self.offset
