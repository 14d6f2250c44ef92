"""The contact network's input: 9 consecutive frames of the 17 fit points in 2D.

movingcam (section 4) feeds 9 frames of 2D keypoints. The frames are taken at the training
data's rate (`NETWORK_FPS`): a 60 fps video uses every second frame, so the window spans the
same time (0.27 s) as in training. Each window is expressed relative to its centre frame:
points minus the centre frame's pelvis (midpoint of the hips), divided by the centre
frame's body height in pixels (the extent of its points), so image position and scale,
which a moving camera changes, carry no information; the motion inside the window and the
confidences (0 where the point was not seen) do. Ends of the clip repeat the end frames.
"""
from __future__ import annotations

import numpy as np

from services.reconstruction.keypoints import FIT_NAMES, NUM_FIT

WINDOW = 9
NETWORK_FPS = 30.0
FEATURES = WINDOW * NUM_FIT * 3
RELATIVE_LIMIT = 4.0  # body heights
_HIPS = [FIT_NAMES.index("RHip"), FIT_NAMES.index("LHip")]


def frame_stride(fps: float) -> int:
    return max(1, int(round(fps / NETWORK_FPS)))


def window_features(points2d: np.ndarray, confidence: np.ndarray, stride: int = 1) -> np.ndarray:
    """(T, FEATURES) float32 from (T, 17, 2) pixels and (T, 17) confidences."""
    frames = len(points2d)
    half = WINDOW // 2
    offsets = np.arange(-half, half + 1) * stride
    index = np.clip(np.arange(frames)[:, None] + offsets[None, :], 0, frames - 1)  # (T, 9)
    points = np.asarray(points2d, np.float64)[index]  # (T, 9, P, 2)
    centre = points[:, half]
    pelvis = centre[:, _HIPS].mean(axis=1)
    height = np.maximum(np.ptp(centre[..., 1], axis=1), np.ptp(centre[..., 0], axis=1))
    height = np.maximum(height, 1.0)
    # clipped: a point far off the body (a wild guess, or a camera almost touching it) says nothing more
    relative = np.clip((points - pelvis[:, None, None, :]) / height[:, None, None, None], -RELATIVE_LIMIT, RELATIVE_LIMIT)
    seen = np.asarray(confidence, np.float64)[index]  # (T, 9, P)
    return np.concatenate([relative.reshape(frames, -1), seen.reshape(frames, -1)], axis=1).astype(np.float32)
