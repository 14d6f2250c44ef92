"""Training data for the contact network, made from mocap clips (movingcam section 4, redone).

movingcam renders motion-capture clips through virtual cameras and labels the contacts from
the capture. Here every DeepMimic clip in `pybullet_data` (and its mirror image) is played
kinematically on the humanoid at `NETWORK_FPS`: looping clips three cycles, the others once,
each at its own pace and at half speed, and six of its poses with a foot down held for two
seconds (`held_poses`).
The 17 fit points (`services.reconstruction.keypoints`) are projected through random
cameras into a 640x480 picture, in the paper's camera settings and one more:
- static: fixed, looking at the clip's mean root position;
- panning: fixed position, turning to keep the root in view;
- tracking: moving along with the root at a fixed offset, looking at it;
- zooming: static or panning with the focal length ramping by 0.6x..1.6x.
Cameras stand 2.5-8 m away at 0.3-2.2 m height, any azimuth, roll within +-3 degrees, with a
focal length that makes the body 30-90% of the picture height at that distance. BlazePose's
faults are imitated: per-point Gaussian noise of 0.5-2% of the body's height in pixels,
confidences 0.75-1 (feet 0.5-1), 3% of points dropped (confidence 0, position held from the
frame before, as the pose track's interpolation does), points outside the picture at low
confidence, and in 40% of sequences one leg occluded for 5-30 frames (confidence x0-0.4,
noise x3). Labels, per foot: the lowest corner of the foot box within `CONTACT_HEIGHT` of the
ground (z = 0) and the foot moving slower than `CONTACT_SPEED` horizontally.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from actors.motion.formats.io import DEEPMIMIC_CLIPS, load_motion
from services.contacts.features import NETWORK_FPS, frame_stride, window_features
from services.reconstruction.body import body_points
from services.reconstruction.keypoints import FIT_NAMES, LEFT_RIGHT_SWAP

IMAGE_W, IMAGE_H = 640, 480
CONTACT_HEIGHT = 0.04  # metres
CONTACT_SPEED = 0.6    # metres per second
CAMERA_KINDS = ("static", "panning", "tracking", "zooming")
# The clips are all lively; people in videos also move slowly or stand (balancing, the
# Pose2Sim clip), so every clip is also played at half speed.
PLAY_SPEEDS = (1.0, 0.5)
# Nor do the clips hold still: the Pose2Sim subject stands on one leg with the other lifted and
# nearly still for a second, and the network trained on lively clips alone called that lifted,
# still foot down (cam01 frames 48-75) and the standing one up (30-44): 0.77 mean accuracy over
# the four cameras against the markers, 0.81 with held poses (`settings.py`). So every clip also
# gives poses held for HOLD_S seconds, the clip creeping on at HOLD_SPEED x its pace: a still foot
# is down only when it is low.
HOLD_S = 2.0
HOLD_SPEED = 0.05
HOLDS_PER_CLIP = 6
FOOT_POINTS = [i for i, n in enumerate(FIT_NAMES) if n[1:] in ("Knee", "Ankle", "Toe", "Heel")]


@dataclass
class ClipBodies:
    """A clip played kinematically: fit points (T, 17, 3), root (T, 3), labels (T, 2) right, left."""

    name: str
    points: np.ndarray
    root: np.ndarray
    contacts: np.ndarray


def _bodies(name: str, motion, times: np.ndarray) -> list[ClipBodies]:
    """The motion's pose at `times` (seconds of the clip) and its mirror image, labelled, one
    picture every 1 / NETWORK_FPS seconds of the played sequence."""
    pose = motion.sample(times)
    with torch.no_grad():
        fit, corners = body_points(torch.as_tensor(pose.root_pos), torch.as_tensor(pose.root_rot),
                                   torch.as_tensor(pose.joint_rot))
    fit, corners = fit.double().numpy(), corners.double().numpy()
    lowest = corners[..., 2].min(axis=-1)  # (T, 2)
    speed = np.linalg.norm(np.gradient(corners.mean(axis=-2)[..., :2], 1.0 / NETWORK_FPS, axis=0), axis=-1)
    contacts = (lowest < CONTACT_HEIGHT) & (speed < CONTACT_SPEED)
    mirror = np.array([1.0, -1.0, 1.0])
    return [ClipBodies(name, fit, pose.root_pos, contacts),
            ClipBodies(f"{name}_mirror", (fit * mirror)[:, LEFT_RIGHT_SWAP], pose.root_pos * mirror, contacts[:, ::-1])]


def play_clip(name: str, speed: float = 1.0) -> list[ClipBodies]:
    """The clip and its mirror image, played at `speed` x its own pace, sampled at NETWORK_FPS."""
    motion = load_motion(f"deepmimic:{name}")
    duration = motion.duration * (3 if motion.loop else 1)
    return _bodies(name if speed == 1.0 else f"{name}_x{speed:g}", motion, np.arange(0.0, duration, speed / NETWORK_FPS))


def held_poses(name: str, rng: np.random.Generator, count: int = HOLDS_PER_CLIP) -> list[ClipBodies]:
    """`count` of the clip's poses with a foot on the ground, each held for HOLD_S seconds while
    the clip creeps on at HOLD_SPEED x its pace (and their mirror images)."""
    motion = load_motion(f"deepmimic:{name}")
    frames = np.arange(0.0, motion.duration, 1.0 / NETWORK_FPS)
    grounded = np.flatnonzero(_bodies(name, motion, frames)[0].contacts.any(axis=1))
    if len(grounded) == 0:
        return []
    steps = np.arange(0.0, HOLD_S, 1.0 / NETWORK_FPS) * HOLD_SPEED
    holds = []
    for k, start in enumerate(rng.choice(frames[grounded], size=min(count, len(grounded)), replace=False)):
        times = np.clip(start + steps - steps[-1] / 2, 0.0, motion.duration)
        holds += _bodies(f"{name}_hold{k}", motion, times)
    return holds


def _look_at(position: np.ndarray, target: np.ndarray, roll: float) -> np.ndarray:
    """(T, 3, 3) world -> camera rotations (OpenCV axes: x right, y down, z forward)."""
    forward = target - position
    forward /= np.linalg.norm(forward, axis=-1, keepdims=True)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.maximum(np.linalg.norm(right, axis=-1, keepdims=True), 1e-9)
    down = np.cross(forward, right)
    c, s = np.cos(roll), np.sin(roll)
    right, down = c * right + s * down, -s * right + c * down
    return np.stack([right, down, forward], axis=-2)


def random_camera_view(body: ClipBodies, rng: np.random.Generator, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """(T, 17, 2) pixels and (T,) in-front mask of the body seen by a random camera of `kind`."""
    frames = len(body.root)
    distance, height = rng.uniform(2.5, 8.0), rng.uniform(0.3, 2.2)
    azimuth = rng.uniform(0, 2 * np.pi)
    offset = np.array([np.cos(azimuth) * distance, np.sin(azimuth) * distance, 0.0])
    centre = body.root.mean(axis=0) * [1, 1, 0] + [0, 0, 0.9]
    following = body.root * [1, 1, 0] + [0, 0, 0.9]
    target = np.repeat(centre[None], frames, 0) if kind in ("static",) else following
    if kind == "zooming" and rng.random() < 0.5:
        target = np.repeat(centre[None], frames, 0)
    position = following + offset if kind == "tracking" else np.repeat(centre[None] + offset, frames, 0)
    position[:, 2] = height
    rotation = _look_at(position, target, np.radians(rng.uniform(-3, 3)))
    focal = np.full(frames, rng.uniform(0.3, 0.9) * IMAGE_H * distance / 1.8)
    if kind == "zooming":
        focal *= np.linspace(1.0, rng.uniform(0.6, 1.6), frames)
    camera = np.einsum("tij,tpj->tpi", rotation, body.points - position[:, None, :])
    depth = camera[..., 2]
    pixels = camera[..., :2] / np.maximum(depth, 1e-3)[..., None] * focal[:, None, None] + [IMAGE_W / 2, IMAGE_H / 2]
    return pixels, (depth > 0.2).all(axis=1)


def blazepose_like(pixels: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Noisy points and confidences the way BlazePose answers (see the module docstring)."""
    frames, count = pixels.shape[:2]
    body = np.maximum(np.ptp(pixels[..., 1], axis=1).mean(), 10.0)
    sigma = np.full((frames, count), rng.uniform(0.005, 0.02) * body)
    confidence = rng.uniform(0.75, 1.0, (frames, count))
    confidence[:, FOOT_POINTS] = rng.uniform(0.5, 1.0, (frames, len(FOOT_POINTS)))
    if rng.random() < 0.4:
        side = "R" if rng.random() < 0.5 else "L"
        leg = [i for i in FOOT_POINTS if FIT_NAMES[i][0] == side]
        start = rng.integers(0, max(frames - 5, 1))
        span = slice(start, start + rng.integers(5, 31))
        confidence[span, leg] *= rng.uniform(0.0, 0.4)
        sigma[span, leg] *= 3.0
    noisy = pixels + rng.normal(size=pixels.shape) * sigma[..., None]
    outside = (noisy[..., 0] < 0) | (noisy[..., 0] > IMAGE_W - 1) | (noisy[..., 1] < 0) | (noisy[..., 1] > IMAGE_H - 1)
    confidence[outside] = rng.uniform(0.0, 0.3, outside.sum())
    dropped = rng.random((frames, count)) < 0.03
    dropped[0] = False
    confidence[dropped] = 0.0
    for t in range(1, frames):  # held from the frame before
        noisy[t, dropped[t]] = noisy[t - 1, dropped[t]]
    return noisy, confidence


@dataclass
class ContactDataset:
    features: np.ndarray  # (N, FEATURES) float32
    labels: np.ndarray    # (N, 2) float32 right, left
    clip: np.ndarray      # (N,) index into `clips`
    clips: tuple[str, ...]


def make_dataset(clips: tuple[str, ...] = DEEPMIMIC_CLIPS, cameras_per_clip: int = 24, seed: int = 0,
                 speeds: tuple[float, ...] = PLAY_SPEEDS, hold_cameras: int = 4) -> ContactDataset:
    """Windows of every clip (and mirror, at each of `speeds`) through `cameras_per_clip` random
    cameras each, the camera kinds taking turns, and of its held poses through `hold_cameras`."""
    rng = np.random.default_rng(seed)
    features, labels, owner = [], [], []
    for index, name in enumerate(clips):
        bodies = [(b, cameras_per_clip) for speed in speeds for b in play_clip(name, speed)]
        bodies += [(b, hold_cameras) for b in held_poses(name, rng)] if hold_cameras else []
        for body, cameras in bodies:
            for k in range(cameras):
                pixels, in_front = random_camera_view(body, rng, CAMERA_KINDS[k % len(CAMERA_KINDS)])
                noisy, confidence = blazepose_like(pixels, rng)
                confidence[~in_front] = 0.0
                window = window_features(noisy, confidence, frame_stride(NETWORK_FPS))
                keep = in_front
                features.append(window[keep])
                labels.append(body.contacts[keep].astype(np.float32))
                owner.append(np.full(int(keep.sum()), index))
    return ContactDataset(np.concatenate(features), np.concatenate(labels), np.concatenate(owner), tuple(clips))
