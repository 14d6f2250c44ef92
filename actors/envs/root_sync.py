"""Re-synchronising the reference's horizontal root with the character's, once per cycle.

DeepMimic (`SceneImitate::SyncKinCharNewCycle`, `--sync_char_root_pos true` for every
humanoid3d clip) moves the kinematic reference's root to the simulated character's (x, y on
the ground) whenever a looped clip starts a new cycle. Within a cycle, drift costs the root
term; across cycles it does not accumulate, so a character that lags 30 cm after the first
step is not scored against a reference that is metres ahead ten cycles later. The reference
table stays shared and read-only: each env keeps an offset added to the reference row's
world positions (root and centre of mass) as it is read.

**The leash** (`EnvConfig.root_leash_m`, 0: off) keeps the reference's horizontal root within that
distance of the character's on every step, looped clip or not: where the character is farther, the
offset moves the reference toward it by the excess. A long non-looped clip (a video of a walk that
crosses the room) has no new cycle to forgive a lag, so the lag grows, and past the tracking
termination's 1 m the policy reaches states no training episode kept (they were ended there) and
falls. With the leash the reference waits for the character: the root term still pays for closing
the gap up to the leash, and the character completes the clip a little behind the video's path.
"""
from __future__ import annotations

import numpy as np

from actors.character.features import RewardFeatures


class RootSync:
    def __init__(self, track, batch: int, enabled: bool = True, leash_m: float = 0.0):
        if not leash_m >= 0:
            raise ValueError(f"root leash must be >= 0 m, got {leash_m}")
        self.per_cycle = enabled and track.motion.loop
        self.leash_m = float(leash_m)
        self.enabled = self.per_cycle or self.leash_m > 0
        # A row starts a new cycle where the phase wraps (exact also for clips whose cycle is
        # not a whole number of control steps, e.g. the 52.5-step backflip).
        self.cycle_start = np.zeros(track.rows, dtype=bool)
        self.cycle_start[1:] = track.phase[1:] < track.phase[:-1]
        self.root_xy = track.qpos[:, :2]
        self.offset = np.zeros((batch, 2))
        self._new_cycle = np.zeros(batch, dtype=bool)
        self._gap = np.zeros((batch, 2))
        self._distance = np.zeros(batch)

    def reset(self, i: int, sim_xy: np.ndarray, row: int) -> None:
        """Env i starts an episode at table row `row` with its root at `sim_xy`."""
        np.subtract(sim_xy, self.root_xy[row], out=self.offset[i])

    def apply(self, rows: np.ndarray, sim_xy: np.ndarray, ref: RewardFeatures) -> None:
        """After a step to `rows` (B,): re-sync the envs that entered a new cycle, then shift
        the gathered reference rows `ref` by each env's offset."""
        if not self.enabled:
            return
        if self.per_cycle:
            np.take(self.cycle_start, rows, out=self._new_cycle)
            if self._new_cycle.any():  # a few times per cycle across the batch
                idx = np.flatnonzero(self._new_cycle)
                self.offset[idx] = sim_xy[idx] - self.root_xy[rows[idx]]
        if self.leash_m > 0:
            self._leash(rows, sim_xy)
        ref.root_xy += self.offset
        ref.com_xy += self.offset

    def _leash(self, rows: np.ndarray, sim_xy: np.ndarray) -> None:
        """Move each env's reference root toward the character's by what its gap exceeds the leash."""
        gap, distance = self._gap, self._distance
        np.subtract(sim_xy, self.root_xy[rows], out=gap)
        gap -= self.offset
        np.hypot(gap[:, 0], gap[:, 1], out=distance)
        far = distance > self.leash_m
        if far.any():  # rare: only where the character has fallen behind by more than the leash
            idx = np.flatnonzero(far)
            self.offset[idx] += gap[idx] * (1.0 - self.leash_m / distance[idx])[:, None]
