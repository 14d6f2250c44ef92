"""Test videos made from real footage: the Pose2Sim person twice (one leaves), and a camera
that pans and zooms over the static Pose2Sim view. Each returns its ground truth."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from services.pose.video import read_frames
from tests.video_helpers import write_clip

CAM01 = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "video" / "pose2sim_balancing" / "cam01.mp4"
WIDTH, HEIGHT = 640, 480
# cam01 (1080x1920) at a quarter: 270x480; the person stands in columns ~50..160, a
# bystander at the far left (columns < 40) is cut away.
STRIP = slice(45, 235)
A_LEFT = 20        # person A's strip stays here
B_LEFT = 340       # person B's strip starts here ...
B_LEAVES = (40, 70)  # ... and slides out to the right between these frames
B_TIME_SHIFT = 50  # B plays the clip 50 frames later, so the two do not move alike


@dataclass(frozen=True)
class TwoPeopleClip:
    path: Path
    frames: int
    b_left: np.ndarray  # (frames,) x of B's strip in the output
    b_gone_from: int    # first frame where B's strip is wholly outside the picture


def _quarter_strips(count: int) -> list[np.ndarray]:
    return [cv2.resize(f, (270, 480), interpolation=cv2.INTER_AREA)[:, STRIP] for _, f in read_frames(CAM01, 0, count)]


def b_strip_left(frames: int) -> np.ndarray:
    start, end = B_LEAVES
    travel = np.clip((np.arange(frames) - start) / (end - start), 0.0, 1.0)
    return np.round(B_LEFT + travel * (WIDTH - B_LEFT)).astype(int)


def two_people_clip(path: Path, frames: int = 100) -> TwoPeopleClip:
    """Person A on the left throughout; person B (the same footage, 50 frames later) on the
    right, walking out of the picture to the right between frames 40 and 70."""
    strips = _quarter_strips(100)
    width = strips[0].shape[1]
    lefts = b_strip_left(frames)
    out = []
    for t in range(frames):
        canvas = np.full((HEIGHT, WIDTH, 3), 110, np.uint8)
        canvas[:, A_LEFT:A_LEFT + width] = strips[t % 100]
        visible = min(width, WIDTH - lefts[t])
        if visible > 0:
            canvas[:, lefts[t]:lefts[t] + visible] = strips[(t + B_TIME_SHIFT) % 100][:, :visible]
        out.append(canvas)
    gone = int(np.argmax(lefts >= WIDTH)) if (lefts >= WIDTH).any() else frames
    return TwoPeopleClip(write_clip(path, out), frames, lefts, gone)


@dataclass(frozen=True)
class MovingCameraClip:
    path: Path
    pan_px: np.ndarray   # (T,) true view motion into each frame, output pixels, + right (0 at frame 0)
    tilt_px: np.ndarray  # (T,) + down
    zoom: np.ndarray     # (T,) true scale from the frame before (1 at frame 0)


def moving_camera_clip(path: Path, frames: int = 60, size: tuple[int, int] = (480, 640)) -> MovingCameraClip:
    """A camera that pans right, tilts down and zooms in 1.3x over the static cam01 view: a crop
    window (centre m_t, width w_t in source pixels) scaled to `size`. An output pixel is
    x = k_t (s - m_t) + c with k_t = width / w_t, so the view moves by k_t (m_t - m_{t-1})
    into frame t and zooms by k_t / k_{t-1}."""
    width, height = size
    t = np.linspace(0.0, 1.0, frames)
    crop_w = 1000.0 - 240.0 * t
    centre = np.stack([500.0 + 200.0 * t, 900.0 + 100.0 * t], axis=1)
    k = width / crop_w
    out_centre = (np.array([width, height], np.float64) - 1.0) / 2.0
    out = []
    for index, frame in read_frames(CAM01, 0, frames):
        matrix = np.array([[k[index], 0.0, out_centre[0] - k[index] * centre[index, 0]],
                           [0.0, k[index], out_centre[1] - k[index] * centre[index, 1]]])
        blurred = cv2.GaussianBlur(frame, (0, 0), 0.5 / k[index])  # against aliasing when shrinking
        out.append(cv2.warpAffine(blurred, matrix, (width, height), flags=cv2.INTER_LINEAR))
    motion = np.zeros((frames, 2))
    motion[1:] = k[1:, None] * np.diff(centre, axis=0)
    zoom = np.ones(frames)
    zoom[1:] = k[1:] / k[:-1]
    return MovingCameraClip(write_clip(path, out), motion[:, 0], motion[:, 1], zoom)
