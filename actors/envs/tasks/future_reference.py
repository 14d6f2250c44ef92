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

from actors.character.features import REFERENCE_OBS_WIDTH, FeatureExtractor, update_kinematics
from actors.character.humanoid3d import HUMANOID3D, Humanoid
from actors.envs.reference_obs import ReferenceObservation

FUTURE_STEPS = 5  # 004 Fig. 1: k = 5


def pose_width(character=HUMANOID3D) -> int:
    """Height, link positions and rotations (the observation's first entries)."""
    return 1 + character.num_links * (3 + 4)


def future_dim(steps: int = FUTURE_STEPS, character=HUMANOID3D) -> int:
    return steps * (pose_width(character) + REFERENCE_OBS_WIDTH)


POSE_WIDTH = pose_width(HUMANOID3D)  # 106
STEP_WIDTH = POSE_WIDTH + REFERENCE_OBS_WIDTH  # 113
FUTURE_DIM = future_dim(FUTURE_STEPS, HUMANOID3D)  # 565


def reference_poses(track, humanoid: Humanoid) -> np.ndarray:
    """(rows, 106 for humanoid3d) egocentric pose of every reference row (computed once per track)."""
    scratch = mujoco.MjData(humanoid.model)
    features = FeatureExtractor(humanoid)
    width = pose_width(humanoid.character)
    obs = np.zeros((1, features.obs_dim))
    poses = np.zeros((track.rows, width))
    for row in range(track.rows):
        scratch.qpos[:] = track.qpos[row]
        scratch.qvel[:] = track.qvel[row]
        update_kinematics(humanoid.model, scratch)
        poses[row] = features.observation(scratch, 0.0, obs)[:width]
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
        self._obs = np.zeros((1, self.features.obs_dim + REFERENCE_OBS_WIDTH * steps))
        self._row = np.zeros(1, dtype=np.int64)
        self.width = future_dim(steps, humanoid.character)
        self.pose_width, self.proprio_dim = self.poses.shape[1], self.features.obs_dim - 1

    def __call__(self, data: mujoco.MjData, row: int, sync_offset: np.ndarray,
                 proprio_out: np.ndarray, future_out: np.ndarray) -> None:
        """Write s_t (196,) and the future features (steps * 113,) of the character in `data`
        (kinematics up to date) at table row `row`; `sync_offset` (1, 2): the env's root-sync offset."""
        k, pose, proprio = self.steps, self.pose_width, self.proprio_dim
        self._row[0] = row
        reference = self.reference_obs.gather(self._row, sync_offset)
        obs = self.features.observation(data, 0.0, self._obs, reference)
        proprio_out[...] = obs[:proprio]
        future = future_out.reshape(k, pose + REFERENCE_OBS_WIDTH)
        np.subtract(self.poses[self.reference_obs.rows[0]], obs[:pose], out=future[:, :pose])
        future[:, pose:pose + 3] = obs[proprio:proprio + 3 * k].reshape(k, 3)
        future[:, pose + 3:] = obs[proprio + 3 * k:proprio + 7 * k].reshape(k, 4)
