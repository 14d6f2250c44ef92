"""The future reference roots a policy observes (MimicKit's `tar_obs_steps`, root only).

The phase tells the policy *when* it is in the clip; with the reference's root re-synced
only once per cycle (`actors/envs/root_sync.py`), it cannot tell *where* the reference is: how far
ahead or behind, how much turned. For each of K step offsets this gathers the reference root
(position, with the env's sync offset, and rotation) at row + k, clamped to the table, into
fixed buffers for `FeatureExtractor.observations(reference=...)`.
"""
from __future__ import annotations

import numpy as np


class ReferenceObservation:
    def __init__(self, track, batch: int, steps: tuple[int, ...]):
        self.steps = np.asarray(steps, dtype=np.int64)
        self.k = len(self.steps)
        self.last_row = track.rows - 1
        self.root_pos = np.ascontiguousarray(track.qpos[:, :3])
        self.root_quat = np.ascontiguousarray(track.qpos[:, 3:7])
        self.rows = np.zeros((batch, self.k), dtype=np.int64)
        self.pos = np.zeros((batch, self.k, 3))
        self.quat = np.zeros((batch, self.k, 4))
        self._pos_xy = self.pos[..., :2]

    def gather(self, rows: np.ndarray, offset: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """(positions (B, K, 3), quaternions (B, K, 4)) of the reference roots K steps after
        each env's `rows` (B,), shifted by the root sync `offset` (B, 2); None when K = 0."""
        if not self.k:
            return None
        np.add(rows[:, None], self.steps, out=self.rows)
        np.minimum(self.rows, self.last_row, out=self.rows)
        np.take(self.root_pos, self.rows, axis=0, out=self.pos)
        np.take(self.root_quat, self.rows, axis=0, out=self.quat)
        self._pos_xy += offset[:, None, :]
        return self.pos, self.quat
