"""The future reference a policy observes: its roots (MimicKit's `tar_obs_steps`), and its pose.

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


class ReferencePoseObservation:
    """The reference's pose K steps ahead, as the policy sees its own (MimicKit's target
    observation with key bodies): the root height and each link's position relative to the
    root in the reference's own heading frame (`ReferenceTrack.pose_obs`, 46 values a step).

    With residual actions the policy outputs corrections to the reference's targets, and a
    correction is a function of how the character's pose differs from the reference's. From
    the phase alone the network must first learn the reference as a function of time; with
    the target pose in the observation the difference is there to read.
    """

    def __init__(self, track, batch: int, steps: tuple[int, ...]):
        self.steps = np.asarray(steps, dtype=np.int64)
        self.k = len(self.steps)
        self.table = track.pose_obs  # (rows, pose width): per step the reference's root height and link positions
        pose_width = self.table.shape[1]
        self.width = self.k * pose_width
        self.last_row = track.rows - 1
        self._rows = np.zeros((batch, self.k), dtype=np.int64)
        self._buf = np.zeros((batch, self.k, pose_width))
        self._flat = self._buf.reshape(batch, self.width)

    def write(self, rows: np.ndarray, out: np.ndarray) -> None:
        """Write the poses K steps after each env's `rows` (B,) into `out` (B, width)."""
        if not self.k:
            return
        np.add(rows[:, None], self.steps, out=self._rows)
        np.minimum(self._rows, self.last_row, out=self._rows)
        np.take(self.table, self._rows, axis=0, out=self._buf)
        out[:] = self._flat
