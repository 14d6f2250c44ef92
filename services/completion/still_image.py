"""The still image: decoded with OpenCV, and BlazePose run on it once (detector + landmarks)."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from learner.errors import SfvError
from services.pose import PoseConfig, PoseTrack, resolve_model_files
from services.pose.estimator import FramePoseEstimator
from services.pose.landmarks import NUM_BODY_LANDMARKS


def read_image(path: str | Path) -> np.ndarray:
    """(H, W, 3) RGB uint8; an SfvError naming the file when it is missing or not an image."""
    path = Path(path)
    if not path.exists():
        raise SfvError(f"{path}: no such image file")
    if not path.is_file():
        raise SfvError(f"{path}: not a file")
    # imdecode on the bytes rather than imread: same decoders, but no warning spam on bad files.
    data = np.fromfile(path, dtype=np.uint8)
    image = cv2.imdecode(data, cv2.IMREAD_COLOR) if data.size else None
    if image is None:
        raise SfvError(f"{path}: not a readable image (OpenCV cannot decode it)")
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)


def estimate_still_pose(image_rgb: np.ndarray, source: str | Path, models_dir: str | Path | None = None,
                        config: PoseConfig | None = None) -> PoseTrack:
    """BlazePose on one image as a one-frame PoseTrack (the form the reconstruction reads).

    A frame that is not confident upright is also tried turned by 90/180/270 degrees, as
    for video frames (acrobatic stills are often upside down)."""
    files = resolve_model_files(models_dir)
    estimate = FramePoseEstimator(files, config).process(image_rgb)
    pose = estimate.pose
    if pose is None:
        raise SfvError(f"{source}: no person detected")
    body = slice(0, NUM_BODY_LANDMARKS)
    height, width = image_rgb.shape[:2]
    return PoseTrack(
        fps=1.0,
        image_size=(width, height),
        keypoints2d=pose.keypoints[None, body].astype(np.float32),
        confidence=pose.visibility[None, body].astype(np.float32),
        world3d=pose.world[None, body].astype(np.float32),
        valid=np.ones(1, bool),
        presence=np.array([pose.presence], np.float32),
        rotation_used=np.array([estimate.rotation_degrees], np.int16),
        filled_frames=0,
    )
