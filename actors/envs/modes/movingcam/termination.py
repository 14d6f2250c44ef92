"""Early termination of the dynamic-camera tracker (002 §5.2), batched over B envs.

"We monitor the CoM height, collision with obstacles, and the deviation from the estimated
poses and body orientation hints to decide if the early termination is needed." The paper
gives no thresholds; these are ours (config fields):

- CoM height: the centre of mass more than `com_drop_m` below the reference's (the root-free
  reference keeps its height: the ground and the body's up direction still fix it).
- Pose: the RMS over the 12 joints of the joint-angle error (the reward's E_q) above
  `joint_angle_error_rad`.
- Orientation: the gap between |hint| and the simulated up-tilt above `orientation_error_rad`
  (frames whose hint is not trusted never end an episode).
- Obstacles: a contact between an obstacle geom and a walker geom other than the flagged end
  effectors' (feet; hands where the motion flags them). The obstacle geom ids come from the
  scene (`MovingcamTracking.set_obstacles`); a flat floor has none.

They add to the clip's contact-fall rule (`actors/envs/falls.py`), which still applies when
`EnvConfig.early_termination` is on; all are off when it is off (evaluation judges falls itself).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

RULES = ("com_height", "joint_angles", "orientation", "obstacle")


@dataclass(frozen=True)
class MovingcamTerminationConfig:
    com_drop_m: float | None = field(default=0.3, metadata={"help": "end the episode when the centre of mass is this far (m) below the reference's (002 §5.2); None: off"})
    joint_angle_error_rad: float | None = field(default=0.6, metadata={"help": "end the episode when the RMS joint-angle error over the 12 joints exceeds this (rad); None: off"})
    orientation_error_rad: float | None = field(default=0.8, metadata={"help": "end the episode when the simulated up-tilt is this far (rad) from the hint's magnitude where the hint is trusted; None: off"})
    obstacle_collision: bool = field(default=True, metadata={"help": "end the episode when a link other than the flagged end effectors touches an obstacle of the scene"})


class MovingcamTermination:
    """`check(...)` -> (B,) bool: which envs break a rule this step; `fired` (B, 4) says which."""

    def __init__(self, config: MovingcamTerminationConfig, batch: int, num_joints: int = 12):
        self.config = config
        self.fired = np.zeros((batch, len(RULES)), dtype=bool)
        self.any = np.zeros(batch, dtype=bool)
        self._scratch = np.zeros(batch)
        limit = config.joint_angle_error_rad
        self._pose_limit = None if limit is None else num_joints * limit * limit  # on the sum of squares

    def check(self, com_z: np.ndarray, ref_com_z: np.ndarray, pose_error: np.ndarray, orientation_gap: np.ndarray,
              obstacle_hit: np.ndarray) -> np.ndarray:
        c, fired, scratch = self.config, self.fired, self._scratch
        if c.com_drop_m is not None:
            np.subtract(ref_com_z, com_z, out=scratch)
            np.greater(scratch, c.com_drop_m, out=fired[:, 0])
        if self._pose_limit is not None:
            np.greater(pose_error, self._pose_limit, out=fired[:, 1])
        if c.orientation_error_rad is not None:
            np.greater(orientation_gap, c.orientation_error_rad, out=fired[:, 2])
        if c.obstacle_collision:
            np.copyto(fired[:, 3], obstacle_hit)
        return np.any(fired, axis=1, out=self.any)
