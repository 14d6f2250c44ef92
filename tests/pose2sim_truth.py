"""Ground truth of the Pose2Sim clip: triangulated markers (.trc) projected into a camera."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import tomllib

from actors.motion.formats.trc import read_trc

CLIP_DIR = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "video" / "pose2sim_balancing"
TRC = CLIP_DIR / "S00_P00_T01_BalancingTrial_0-100.trc"


def markers(path: Path = TRC) -> tuple[list[str], np.ndarray]:
    """Marker names and (T, M, 3) positions in the calibration's world frame (metres, z up)."""
    return read_trc(path)


def project(points: np.ndarray, camera: str = "cam_01") -> np.ndarray:
    """(..., 3) world points -> (..., 2) pixels of that camera."""
    calibration = tomllib.loads((CLIP_DIR / "Calib_qualisys.toml").read_text())[camera]
    flat = points.reshape(-1, 3).astype(np.float64)
    pixels, _ = cv2.projectPoints(flat, np.array(calibration["rotation"]), np.array(calibration["translation"]),
                                  np.array(calibration["matrix"]), np.array(calibration["distortions"]))
    return pixels.reshape(points.shape[:-1] + (2,))


FOOT_MARKERS = {"right": ("RHeel", "RBigToe", "RSmallToe"), "left": ("LHeel", "LBigToe", "LSmallToe")}
MARKER_CONTACT_HEIGHT = 0.05  # metres above the foot's own lowest point in the clip
MARKER_CONTACT_SPEED = 0.6    # metres per second, as the training labels


def marker_contacts(filtered: Path = CLIP_DIR / "S00_P00_T01_BalancingTrial_0-100_filt_butterworth.trc") -> np.ndarray:
    """(T, 2) right, left contact flags from the filtered markers: the lowest foot marker within
    5 cm of that foot's lowest height in the clip (the person stands on a raised plate with one
    foot and steps down beside it with the other, so there is no one floor) and the foot's
    markers moving slower than 0.6 m/s horizontally. `filtered`: another person's (or trial's) markers."""
    names, world = markers(filtered)
    flags = []
    for foot in ("right", "left"):
        index = [names.index(n) for n in FOOT_MARKERS[foot]]
        height = world[:, index, 2].min(axis=1)
        speed = np.linalg.norm(np.gradient(world[:, index].mean(axis=1)[:, :2], 1 / 60.0, axis=0), axis=1)
        flags.append((height < height.min() + MARKER_CONTACT_HEIGHT) & (speed < MARKER_CONTACT_SPEED))
    return np.stack(flags, axis=1)
