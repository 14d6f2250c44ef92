"""The motor module's encoder input: the next k reference states relative to the character.

004 §3.3 / Fig. 1: the encoder q(z_t | z_{t-1}, s_{t+1..t+k}) sees the desired states of the
next k = 5 control steps. Here each future reference row r = row + j (j = 1..k, clamped to the
table's last row, as `actors/envs/reference_obs.py` does) contributes `STEP_WIDTH` = 113 numbers:

- `POSE_WIDTH` = 106: the reference's egocentric pose at r (root height, 15 link positions
  relative to its root, 15 link rotations, each in its own heading frame: the first 106
  entries of the proprioception, `actors/envs/tasks/proprioception.py`) minus the character's current
  ones: how the body must change, independent of where it stands;
- 7: the reference root at r (with the env's root-sync offset) in the character's heading
  frame, position relative to the character's root and rotation (`REFERENCE_OBS_WIDTH`): where
  it must go and which way it must turn.

Velocities are left out (the 5 consecutive poses carry them); `FUTURE_DIM` = 5 x 113 = 565.
Deviation from 004: its encoder also sees object states; the scenes here hold no objects.
"""
from __future__ import annotations

import mujoco
import numpy as np

from actors.character.features import REFERENCE_OBS_WIDTH, FeatureExtractor, observation_dim, update_kinematics
from actors.character.humanoid import Humanoid
from actors.envs.tasks.proprioception import PROPRIO_DIM
from actors.envs.reference_obs import ReferenceObservation
from actors.character.skeleton import NUM_LINKS

FUTURE_STEPS = 5  # 004 Fig. 1: k = 5
POSE_WIDTH = 1 + NUM_LINKS * (3 + 4)  # 106: height, link positions and rotations
STEP_WIDTH = POSE_WIDTH + REFERENCE_OBS_WIDTH  # 113
FUTURE_DIM = FUTURE_STEPS * STEP_WIDTH  # 565


def future_dim(steps: int = FUTURE_STEPS) -> int:
    return steps * STEP_WIDTH


def reference_poses(track, humanoid: Humanoid) -> np.ndarray:
    """(rows, 106) egocentric pose of every reference row (computed once per track)."""
    scratch = mujoco.MjData(humanoid.model)
    features = FeatureExtractor(humanoid)
    obs = np.zeros((1, observation_dim(0)))
    poses = np.zeros((track.rows, POSE_WIDTH))
    for row in range(track.rows):
        scratch.qpos[:] = track.qpos[row]
        scratch.qvel[:] = track.qvel[row]
        update_kinematics(humanoid.model, scratch)
        poses[row] = features.observation(scratch, 0.0, obs)[:POSE_WIDTH]
    return poses


class FutureReference:
    """Proprioception s_t and the encoder's future features of one env, per control step."""

    def __init__(self, track, humanoid: Humanoid, steps: int = FUTURE_STEPS):
        if steps < 1:
            raise ValueError(f"future reference: steps must be >= 1, got {steps}")
        self.steps = steps
        self.poses = reference_poses(track, humanoid)
        self.features = FeatureExtractor(humanoid)
        self.reference_obs = ReferenceObservation(track, 1, tuple(range(1, steps + 1)))
        self._obs = np.zeros((1, observation_dim(steps)))
        self._row = np.zeros(1, dtype=np.int64)
        self.width = future_dim(steps)

    def __call__(self, data: mujoco.MjData, row: int, sync_offset: np.ndarray,
                 proprio_out: np.ndarray, future_out: np.ndarray) -> None:
        """Write s_t (196,) and the future features (steps * 113,) of the character in `data`
        (kinematics up to date) at table row `row`; `sync_offset` (1, 2): the env's root-sync offset."""
        k = self.steps
        self._row[0] = row
        reference = self.reference_obs.gather(self._row, sync_offset)
        obs = self.features.observation(data, 0.0, self._obs, reference)
        proprio_out[...] = obs[:PROPRIO_DIM]
        future = future_out.reshape(k, STEP_WIDTH)
        np.subtract(self.poses[self.reference_obs.rows[0]], obs[:POSE_WIDTH], out=future[:, :POSE_WIDTH])
        future[:, POSE_WIDTH:POSE_WIDTH + 3] = obs[PROPRIO_DIM:PROPRIO_DIM + 3 * k].reshape(k, 3)
        future[:, POSE_WIDTH + 3:] = obs[PROPRIO_DIM + 3 * k:PROPRIO_DIM + 7 * k].reshape(k, 4)
