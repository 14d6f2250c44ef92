"""q_bar: the humanoid pose of the actor in the image.

BlazePose's world landmarks are fitted with the motion reconstruction's per-frame fit
(`services.reconstruction.initial_fit`, bone directions, joints kept in their limits). One
image says nothing about the ground, so the camera is assumed level (image up = world up):
the person's lean is kept, which the frame matching compares. The root height puts the
lowest corner of the feet on the ground.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from actors.character import quaternion as qn
from services.reconstruction.body import body_points
from services.reconstruction.camera import CAMERA_DOWN, camera_rotation_from_up
from services.reconstruction.initial_fit import fit_poses_to_points
from services.reconstruction.keypoints import observe


@dataclass
class TargetPose:
    """Humanoid poses (leading batch dimension N) in a Z-up world whose x is the image's right
    and whose y points away from the camera."""

    root_rot: np.ndarray  # (N, 4) wxyz
    joint_rot: np.ndarray  # (N, 12, 4) parent-local, skeleton order
    root_height: np.ndarray  # (N,) metres: root above the ground when the lowest foot corner touches it

    def __len__(self) -> int:
        return len(self.root_rot)


def level_camera_rotation() -> np.ndarray:
    """World -> camera rotation of a level camera (see `services.reconstruction.camera`)."""
    return camera_rotation_from_up(-CAMERA_DOWN)


def fit_target_pose(points_camera: np.ndarray, iterations: int, lr: float) -> TargetPose:
    """Humanoid poses whose bone directions match fit points (N, P, 3) given in camera axes."""
    rotation = level_camera_rotation()
    params = fit_poses_to_points(points_camera @ rotation, iterations, lr)  # rows: camera -> world is p @ R
    with torch.no_grad():
        _, foot_corners = body_points(params.root_pos, params.root_quat(), params.joint_quats())
    pose = params.numpy()
    lowest = foot_corners[..., 2].flatten(1).min(dim=1).values.double().numpy()
    return TargetPose(qn.quat_normalize(pose["root_quat"]), qn.quat_normalize(pose["joint_quats"]), -lowest)


def target_pose_from_track(track, iterations: int, lr: float) -> TargetPose:
    """q_bar of every frame of a `services.pose.PoseTrack` (one frame for a still image)."""
    return fit_target_pose(observe(track).points3d, iterations, lr)
