"""Pan, tilt and zoom per frame from the background homographies, and whether the camera moved.

For frame t, H_t maps frame t-1 pixels to frame t pixels (`camera_motion.py`). At the image
centre c the content moves by H_t(c) - c; the view moves the other way, so
    pan_t, tilt_t = -(H_t(c) - c)   (pixels of frame t; + = the view turns right / down)
    zoom_t = sqrt|det J_t(c)|        (J the homography's Jacobian at c; > 1 = zooming in).
The cumulative path chains H_t ... H_1 (frame 0 -> frame t). `--camera auto` calls the
camera moving when the cumulative view offset exceeds `MOVE_FRACTION` of the image width
or the cumulative zoom leaves 1 by more than `ZOOM_TOLERANCE`; a static camera drifts far
less (measured on the static Pose2Sim clip: under 0.5 px and 0.1% over 100 frames).
Untracked frames (NaN homography) count as "no motion" in the path and are counted.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from learner.errors import SfvError

MOVE_FRACTION = 0.02
ZOOM_TOLERANCE = 0.02
MAX_UNTRACKED_FRACTION = 0.5
CAMERA_MODES = ("static", "moving", "auto")


@dataclass(frozen=True)
class CameraPath:
    pan_px: np.ndarray      # (T,) view motion into frame t, + right
    tilt_px: np.ndarray     # (T,) + down
    zoom: np.ndarray        # (T,) scale factor from frame t-1
    tracked: np.ndarray     # (T,) bool: the background gave a homography
    offset_px: np.ndarray   # (T, 2) cumulative view offset from frame 0 (at the image centre)
    total_zoom: np.ndarray  # (T,) cumulative zoom from frame 0

    @property
    def untracked_frames(self) -> int:
        return int((~self.tracked[1:]).sum())  # frame 0 has no predecessor


def _at_centre(homography: np.ndarray, centre: np.ndarray) -> tuple[np.ndarray, float]:
    """Where H sends the centre, and its local scale there."""
    mapped = homography @ np.append(centre, 1.0)
    w = mapped[2]
    point = mapped[:2] / w
    jacobian = (homography[:2, :2] - np.outer(point, homography[2, :2])) / w
    return point, float(np.sqrt(abs(np.linalg.det(jacobian))))


def camera_path(homographies: np.ndarray, image_size: tuple[int, int]) -> CameraPath:
    frames = len(homographies)
    centre = (np.asarray(image_size, np.float64) - 1.0) / 2.0
    tracked = np.isfinite(homographies).all(axis=(1, 2))
    steps = np.where(tracked[:, None, None], homographies, np.eye(3))
    pan, tilt, zoom = np.zeros(frames), np.zeros(frames), np.ones(frames)
    offset, total_zoom = np.zeros((frames, 2)), np.ones(frames)
    chained = np.eye(3)
    for t in range(frames):
        point, zoom[t] = _at_centre(steps[t], centre)
        pan[t], tilt[t] = centre - point
        chained = steps[t] @ chained
        chained /= chained[2, 2]
        point, total_zoom[t] = _at_centre(chained, centre)
        offset[t] = centre - point
    return CameraPath(pan, tilt, zoom, tracked, offset, total_zoom)


def decide_camera(mode: str, path: CameraPath | None, image_width: int, source: str) -> bool:
    """True when the camera is to be treated as moving. `auto` decides from the path, takes a
    static camera where there is no path (tracks from before camera tracking), and refuses
    (one line) when most frames' background could not be tracked."""
    if mode not in CAMERA_MODES:
        raise SfvError(f"--camera {mode!r}: expected one of {', '.join(CAMERA_MODES)}")
    if mode != "auto":
        return mode == "moving"
    if path is None:
        return False  # a track made before camera tracking: SFV's static camera, as it was then
    frames = max(len(path.tracked) - 1, 1)
    if path.untracked_frames > MAX_UNTRACKED_FRACTION * frames:
        raise SfvError(f"{source}: no background could be tracked in {path.untracked_frames} of {frames} frames "
                       "(the camera moves too much, or people fill the picture); pass --camera static or --camera moving")
    offset = float(np.linalg.norm(path.offset_px, axis=1).max())
    zoom = float(np.abs(np.log(path.total_zoom)).max())
    return bool(offset > MOVE_FRACTION * image_width or zoom > np.log1p(ZOOM_TOLERANCE))
