"""Ground-truth errors of a video's pipeline run where Pose2Sim markers lie beside the video.

A folder with `Calib_qualisys.toml` and triangulated `*.trc` files (one per person; the
Butterworth-filtered copies are skipped) gives 3D truth. The person the pipeline followed is
the `.trc` whose 12 joints project nearest the subject's 2D keypoints through the video's
camera (`camNN.mp4` -> `[cam_NN]`; the `.trc` axes permuted as `actors/motion/formats/trc.py`
reads them). BlazePose's raw 3D prediction (`raw_keypoints3d`), the kinematic reference
(`keypoints3d` of motion.npz) and the simulated motion (simulated.npz) are compared with it on the controller's grid, hip-centred
(`services.reconstruction.metrics.evaluate`: PA-MPJPE, MPJPE after one similarity,
acceleration error, mm), over the frames where every marker was triangulated.
"""
from __future__ import annotations

import re
import tomllib
from pathlib import Path

import numpy as np

CALIBRATION = "Calib_qualisys.toml"


def camera_key(video: Path) -> str | None:
    match = re.fullmatch(r"cam(\d+)", video.stem)
    return f"cam_{int(match.group(1)):02d}" if match else None


def project(points: np.ndarray, calibration: dict) -> np.ndarray:
    import cv2

    flat = points.reshape(-1, 3).astype(np.float64)
    pixels, _ = cv2.projectPoints(flat, np.array(calibration["rotation"], np.float64),
                                  np.array(calibration["translation"], np.float64),
                                  np.array(calibration["matrix"], np.float64),
                                  np.array(calibration["distortions"], np.float64))
    return pixels.reshape(points.shape[:-1] + (2,))


def marker_files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.glob("*.trc") if "filt" not in p.name)


def followed_truth(video: Path, keypoints2d: np.ndarray, frames: np.ndarray) -> tuple[Path, np.ndarray] | None:
    """(the .trc, its 12 joints (F, 12, 3) at video `frames`) of the person whose markers project
    nearest `keypoints2d` (F, 12, 2); None without markers or a calibration for this camera."""
    from actors.motion.formats.trc import read_trc
    from services.reconstruction import JOINT_KEYPOINTS

    key, calibration_file = camera_key(video), video.parent / CALIBRATION
    if key is None or not calibration_file.is_file():
        return None
    calibration = tomllib.loads(calibration_file.read_text()).get(key)
    candidates = []
    for path in marker_files(video.parent):
        names, world = read_trc(path)
        if frames.max() >= len(world):
            continue
        joints = world[frames][:, [names.index(n) for n in JOINT_KEYPOINTS]]
        distance = np.linalg.norm(project(joints, calibration) - keypoints2d, axis=-1)
        candidates.append((float(np.nanmedian(distance)), path, joints))
    if calibration is None or not candidates:
        return None
    _, path, joints = min(candidates, key=lambda c: c[0])
    return path, joints


def truth_errors(video: Path, report: dict, motion, simulated, alone=None) -> dict | None:
    """{"trc", "frames", "kinematic": {...}, "simulated": {...}, "raw": {...}} in mm, or None without truth;
    with `alone` (the body-alone stage's simulated motion, on the same control steps) "body_alone" too."""
    from services.pipeline.report import video_rows
    from services.reconstruction import JOINT_KEYPOINTS
    from services.reconstruction.metrics import evaluate

    hz = float(report["control_hz"])
    rows = video_rows(motion, np.arange(simulated.num_frames) / hz)
    frames = int(motion.extras.get("video_start_frame", 0)) + rows
    found = followed_truth(video, np.asarray(motion.extras["keypoints2d"])[rows], frames)
    if found is None:
        return None
    path, truth = found
    whole = np.isfinite(truth).all(axis=(1, 2))
    hips = [JOINT_KEYPOINTS.index("RHip"), JOINT_KEYPOINTS.index("LHip")]
    motions = {"kinematic": np.asarray(motion.extras["keypoints3d"])[rows], "simulated": simulated.extras["keypoints3d"]}
    if "raw_keypoints3d" in motion.extras:
        motions["raw"] = np.asarray(motion.extras["raw_keypoints3d"])[rows]
    if alone is not None and alone.num_frames == simulated.num_frames:
        motions["body_alone"] = alone.extras["keypoints3d"]
    result = {"trc": path.name, "frames": int(whole.sum())}
    for name, points in motions.items():
        result[name] = {k: round(v, 1) for k, v in evaluate(points[whole], truth[whole], hips).items()}
    return result
