"""Ground truth of the Pose2Sim clip: triangulated markers (.trc) projected into a camera."""
from __future__ import annotations

import tomllib
from pathlib import Path

import cv2
import numpy as np

CLIP_DIR = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "video" / "pose2sim_balancing"
TRC = CLIP_DIR / "S00_P00_T01_BalancingTrial_0-100.trc"


def markers() -> tuple[list[str], np.ndarray]:
    """Marker names and (T, M, 3) positions in the calibration's world frame (metres)."""
    lines = TRC.read_text().splitlines()
    names = [n for n in lines[3].split("\t")[2:] if n]
    data = np.array([[float(v) for v in line.split("\t")[2:2 + 3 * len(names)]] for line in lines[5:] if line.strip()])
    trc = data.reshape(len(data), len(names), 3)
    return names, trc[..., [2, 0, 1]]  # the .trc axes are permuted against the calibration's world


def project(points: np.ndarray, camera: str = "cam_01") -> np.ndarray:
    """(..., 3) world points -> (..., 2) pixels of that camera."""
    calibration = tomllib.loads((CLIP_DIR / "Calib_qualisys.toml").read_text())[camera]
    flat = points.reshape(-1, 3).astype(np.float64)
    pixels, _ = cv2.projectPoints(flat, np.array(calibration["rotation"]), np.array(calibration["translation"]),
                                  np.array(calibration["matrix"]), np.array(calibration["distortions"]))
    return pixels.reshape(points.shape[:-1] + (2,))
