"""A pose track made from a known humanoid motion seen by a known camera, with the noise of a
per-frame estimator added: ground truth for testing and benchmarking the reconstruction.

`make_clip`: the humanoid sways, bends its knees and swings its arms (every joint inside its
limits, feet on or above the ground) while walking slowly past the camera.
`make_standing_clip`: it stands on both feet while the estimator misreads one foot as lifted.
`make_one_leg_clip`: it balances on its right foot, the left leg out to the side. Its fit points are
projected through the camera (2D keypoints, plus pixel noise) and expressed hip-centred in
the camera's axes (the "3D prediction", plus per-frame noise in metres: the jitter the
reconstruction should remove).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from actors.character import quaternion as qn
from actors.character.skeleton import JOINT_NAMES, REVOLUTE_JOINTS, SPHERICAL_JOINTS
from services.pose.track import KEYPOINT_NAMES, PoseTrack
from services.reconstruction.body import REVOLUTE_LIMITS, SOLE_CORNERS, SPHERICAL_LIMITS, PoseParams, body_points
from services.reconstruction.camera import PinholeCamera, camera_rotation_from_up
from services.reconstruction.keypoints import FIT_POINTS, NUM_JOINT_KEYPOINTS, fit_index

EAR_HALF_WIDTH = 0.07  # metres either side of the head centre


@dataclass
class SyntheticClip:
    track: PoseTrack
    camera: PinholeCamera
    joints3d: np.ndarray  # (T, 12, 3) true world positions of the 12 joint keypoints
    root_pos: np.ndarray  # (T, 3)
    root_quat: np.ndarray  # (T, 4)
    joint_quats: np.ndarray  # (T, 12, 4)


def _joint_motion(frames: int, fps: float) -> tuple[np.ndarray, np.ndarray]:
    """Smooth spherical rotation vectors (T, 8, 3) and hinge angles (T, 4), inside the limits."""
    t = np.arange(frames)[:, None, None] / fps
    phase = np.arange(len(SPHERICAL_JOINTS))[None, :, None] * 0.7 + np.arange(3)[None, None, :] * 1.3
    centre = SPHERICAL_LIMITS.mean(axis=-1)
    half = 0.5 * (SPHERICAL_LIMITS[..., 1] - SPHERICAL_LIMITS[..., 0])
    # Gentle motion about the middle of each axis' range, kept well inside it.
    spherical = 0.15 * centre + 0.25 * half * np.sin(2.0 * np.pi * 0.6 * t + phase)
    hinge_t = np.arange(frames)[:, None] / fps
    hinge_mid = REVOLUTE_LIMITS.mean(axis=-1)
    revolute = hinge_mid + 0.35 * np.sin(2.0 * np.pi * 0.8 * hinge_t + np.arange(len(REVOLUTE_JOINTS)))
    revolute = np.where(np.isin([JOINT_NAMES[j] for j in REVOLUTE_JOINTS], ("right_knee", "left_knee")),
                        np.clip(revolute * 0.5, -1.2, -0.1), revolute)
    return spherical, np.clip(revolute, REVOLUTE_LIMITS[:, 0], REVOLUTE_LIMITS[:, 1])


def _landmarks(fit: np.ndarray, neck_left: np.ndarray) -> np.ndarray:
    """BlazePose's 33 landmarks (T, 33, 3) from the fit points (T, P, 3): each landmark the
    fit uses sits where the fit expects it; the others copy the nearest body part."""
    landmarks = np.empty(fit.shape[:1] + (len(KEYPOINT_NAMES), 3))
    head = fit[:, fit_index("Head")]
    source = {point.blazepose[0]: fit[:, i] for i, point in enumerate(FIT_POINTS) if len(point.blazepose) == 1}
    source["left_ear"] = head + EAR_HALF_WIDTH * neck_left
    source["right_ear"] = head - EAR_HALF_WIDTH * neck_left
    for k, name in enumerate(KEYPOINT_NAMES):
        if name in source:
            landmarks[:, k] = source[name]
        elif any(part in name for part in ("pinky", "index", "thumb")):
            landmarks[:, k] = fit[:, fit_index("LWrist" if name.startswith("left") else "RWrist")]
        else:  # nose, eyes, mouth
            landmarks[:, k] = head
    return landmarks


def _standard_camera(image_size: tuple[int, int], focal: float) -> PinholeCamera:
    """A camera 4 m in front (along -y), 1.2 m up, looking 10 degrees down."""
    pitch = np.deg2rad(10.0)
    up_cam = np.array([0.0, -np.cos(pitch), -np.sin(pitch)])
    return PinholeCamera(camera_rotation_from_up(up_cam), np.array([0.0, -4.0, 1.2]), focal,
                         np.array([(image_size[0] - 1) / 2, (image_size[1] - 1) / 2]), tuple(image_size))


def _posed(root_pos, root_quat, spherical, revolute, per_frame_ground: bool):
    """Fit points (T, P, 3), root positions, joint quaternions and foot corners of a pose
    trajectory lifted so that its lowest foot point touches z = 0 (every frame's, or the clip's)."""
    params = PoseParams.create(root_pos, root_quat, spherical, revolute)
    with torch.no_grad():
        fit, corners = body_points(params.root_pos, params.root_quat(), params.joint_quats())
        joint_quats = params.joint_quats().numpy()
    fit, corners = fit.numpy(), corners.numpy()
    lowest = corners[..., 2].reshape(len(fit), -1).min(axis=1)
    lift = -lowest if per_frame_ground else np.full(len(fit), -lowest.min())
    return fit + lift[:, None, None] * np.array([0.0, 0.0, 1.0]), root_pos + lift[:, None] * np.array([0.0, 0.0, 1.0]), \
        joint_quats, corners + lift[:, None, None, None] * np.array([0.0, 0.0, 1.0])


def _seen(fit, root_quat, joint_quats, camera: PinholeCamera, fps: float, pixel_noise: float, depth_noise_m: float,
          rng: np.random.Generator, misread=None) -> PoseTrack:
    """The pose track a per-frame estimator gives of the fit points (`misread`: landmarks
    -> landmarks, an estimator's systematic error, applied before the noise)."""
    neck_left = qn.quat_rotate(qn.quat_mul(root_quat, joint_quats[:, 0]), np.array([0.0, 1.0, 0.0]))  # chest's +y
    world_landmarks = _landmarks(fit, neck_left)
    if misread is not None:
        world_landmarks = misread(world_landmarks)
    keypoints2d = camera.project(world_landmarks) + rng.normal(0.0, pixel_noise, world_landmarks.shape[:-1] + (2,))
    hips = world_landmarks[:, [KEYPOINT_NAMES.index("left_hip"), KEYPOINT_NAMES.index("right_hip")]].mean(axis=1)
    world3d = (world_landmarks - hips[:, None]) @ camera.rotation.T + rng.normal(0.0, depth_noise_m, world_landmarks.shape)
    frames = len(fit)
    return PoseTrack(
        fps=fps, image_size=tuple(camera.image_size),
        keypoints2d=keypoints2d.astype(np.float32), confidence=np.full((frames, len(KEYPOINT_NAMES)), 0.95, np.float32),
        world3d=world3d.astype(np.float32), valid=np.ones(frames, bool), presence=np.ones(frames, np.float32),
        rotation_used=np.zeros(frames, np.int16), filled_frames=0,
    )


def make_clip(frames: int = 40, fps: float = 30.0, image_size: tuple[int, int] = (640, 480), focal: float = 600.0,
              pixel_noise: float = 2.0, depth_noise_m: float = 0.04, seed: int = 0) -> SyntheticClip:
    rng = np.random.default_rng(seed)
    spherical, revolute = _joint_motion(frames, fps)
    t = np.arange(frames) / fps
    yaw = 0.3 * np.sin(2.0 * np.pi * 0.3 * t) - np.pi / 2  # facing the camera (-y), turning a little
    root_quat = qn.quat_from_axis_angle(np.stack((np.zeros(frames), np.zeros(frames), yaw), axis=-1))
    root_pos = np.stack((0.3 * t - 0.15 * t[-1], np.zeros(frames), np.full(frames, 1.0)), axis=-1)
    fit, root_pos, joint_quats, _ = _posed(root_pos, root_quat, spherical, revolute, per_frame_ground=False)
    camera = _standard_camera(image_size, focal)
    track = _seen(fit, root_quat, joint_quats, camera, fps, pixel_noise, depth_noise_m, rng)
    return SyntheticClip(track, camera, fit[:, :NUM_JOINT_KEYPOINTS], root_pos, root_quat, joint_quats)


RIGHT_FOOT_LANDMARKS = ("right_ankle", "right_heel", "right_foot_index")


def make_standing_clip(frames: int = 30, fps: float = 30.0, image_size: tuple[int, int] = (640, 480),
                       focal: float = 600.0, right_foot_misread_m: float = 0.08, pixel_noise: float = 1.0,
                       depth_noise_m: float = 0.02, seed: int = 0) -> SyntheticClip:
    """A person standing on both feet, facing the camera, moving the arms and upper body, whom
    the estimator reads with the right foot `right_foot_misread_m` higher than it is (in 2D and
    3D alike, as BlazePose reads a foot it sees end-on): a reconstruction that believes the
    keypoints lifts that foot off the floor, though both feet are down in every frame."""
    rng = np.random.default_rng(seed)
    spherical, revolute = _joint_motion(frames, fps)
    legs = [k for k, j in enumerate(SPHERICAL_JOINTS) if "hip" in JOINT_NAMES[j] or "ankle" in JOINT_NAMES[j]]
    spherical[:, legs] = 0.0  # straight legs, feet flat: both soles on the floor
    knees = np.isin([JOINT_NAMES[j] for j in REVOLUTE_JOINTS], ("right_knee", "left_knee"))
    revolute[:, knees] = 0.0
    yaw = np.full(frames, -np.pi / 2)
    root_quat = qn.quat_from_axis_angle(np.stack((np.zeros(frames), np.zeros(frames), yaw), axis=-1))
    fit, root_pos, joint_quats, _ = _posed(np.tile([0.0, 0.0, 1.0], (frames, 1)), root_quat, spherical, revolute,
                                           per_frame_ground=True)
    camera = _standard_camera(image_size, focal)
    lifted = [KEYPOINT_NAMES.index(n) for n in RIGHT_FOOT_LANDMARKS]

    def misread(landmarks):
        landmarks = landmarks.copy()
        landmarks[:, lifted, 2] += right_foot_misread_m
        return landmarks

    track = _seen(fit, root_quat, joint_quats, camera, fps, pixel_noise, depth_noise_m, rng, misread)
    return SyntheticClip(track, camera, fit[:, :NUM_JOINT_KEYPOINTS], root_pos, root_quat, joint_quats)


def _one_leg_pose(steer: np.ndarray, left_hip_out: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rotation vectors (8, 3), hinges (4,) of a humanoid facing -y on its right leg, the right hip
    turned by `steer` (about x, then y) and the right ankle back by as much (the sole stays level),
    the left hip `left_hip_out` radians out to the side; and the gap (2,) from the right sole's
    centre to the centre of mass, horizontally."""
    spherical, revolute = np.zeros((8, 3)), np.zeros(4)
    balls = list(SPHERICAL_JOINTS)
    right_hip, right_ankle, left_hip = (balls.index(JOINT_NAMES.index(n)) for n in ("right_hip", "right_ankle", "left_hip"))
    spherical[right_hip, :2], spherical[right_ankle, :2] = steer, -steer
    spherical[left_hip, 0] = left_hip_out
    params = PoseParams.create(np.array([[0.0, 0.0, 1.0]]), qn.quat_from_axis_angle(np.array([[0.0, 0.0, -np.pi / 2]])),
                               spherical[None], revolute[None])
    with torch.no_grad():
        _, corners, com = body_points(params.root_pos, params.root_quat(), params.joint_quats(), with_com=True)
    sole = corners[0, 0, SOLE_CORNERS].mean(dim=0)
    return spherical, revolute, (com[0, :2] - sole[:2]).numpy()


def make_one_leg_clip(frames: int = 16, fps: float = 30.0, image_size: tuple[int, int] = (640, 480), focal: float = 600.0,
                      left_hip_out: float = 0.5, pixel_noise: float = 1.0, depth_noise_m: float = 0.02,
                      seed: int = 0) -> SyntheticClip:
    """A person balancing on the right foot, the left leg held out to the side, facing the camera:
    the centre of mass exactly over the right sole's centre (the right hip steered under it by
    Newton steps), so the truth is a balance a body holds. The ankle-to-shoulder axis of this
    pose leans towards the raised leg, as a real one-leg stand's does."""
    rng = np.random.default_rng(seed)
    steer = np.zeros(2)
    for _ in range(6):  # the gap is near linear in the steer: a few Newton steps with a numeric Jacobian
        spherical, revolute, gap = _one_leg_pose(steer, left_hip_out)
        jacobian = np.stack([(_one_leg_pose(steer + 1e-4 * e, left_hip_out)[2] - gap) / 1e-4 for e in np.eye(2)], axis=1)
        steer = steer - np.linalg.solve(jacobian, gap)
    spherical, revolute, _ = _one_leg_pose(steer, left_hip_out)
    root_quat = qn.quat_from_axis_angle(np.tile([0.0, 0.0, -np.pi / 2], (frames, 1)))
    fit, root_pos, joint_quats, _ = _posed(np.tile([0.0, 0.0, 1.0], (frames, 1)), root_quat,
                                           np.tile(spherical, (frames, 1, 1)), np.tile(revolute, (frames, 1)),
                                           per_frame_ground=True)
    camera = _standard_camera(image_size, focal)
    track = _seen(fit, root_quat, joint_quats, camera, fps, pixel_noise, depth_noise_m, rng)
    return SyntheticClip(track, camera, fit[:, :NUM_JOINT_KEYPOINTS], root_pos, root_quat, joint_quats)
