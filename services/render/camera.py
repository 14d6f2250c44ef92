"""A free camera that follows a point on the floor with exponential smoothing."""
from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np


@dataclass(frozen=True)
class CameraConfig:
    distance: float = field(default=4.0, metadata={"help": "metres from the camera to the point it looks at"})
    azimuth: float = field(default=130.0, metadata={"help": "degrees; 90 looks along +y (a side view of a character walking along +x), 130 a three-quarter front view"})
    elevation: float = field(default=-12.0, metadata={"help": "degrees; negative looks down"})
    lookat_height: float = field(default=0.85, metadata={"help": "height (m) of the point looked at, about the hips"})
    smoothing: float = field(default=0.15, metadata={"help": "fraction of the way the camera moves toward its target per frame (1: rigidly attached)"})


class FollowCamera:
    def __init__(self, config: CameraConfig = CameraConfig()):
        self.config = config
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        self.camera.distance = config.distance
        self.camera.azimuth = config.azimuth
        self.camera.elevation = config.elevation
        self.camera.lookat[2] = config.lookat_height

    def snap(self, target_xy: np.ndarray) -> None:
        """Jump straight to the target (a new episode)."""
        self.camera.lookat[:2] = target_xy

    def follow(self, target_xy: np.ndarray) -> None:
        """Move part of the way to the target, so that the gait's sway does not shake the view."""
        lookat = self.camera.lookat
        lookat[:2] += self.config.smoothing * (target_xy - lookat[:2])
