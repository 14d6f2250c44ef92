"""Per-frame human pose estimation from video (MediaPipe BlazePose "full"), as Ray tasks.

    track = estimate_video("clip.mp4", use_ray=True)   # -> PoseTrack
    track.save("clip_pose.npz")

`estimate_video` (OpenCV, the models' runtime) loads on first use, so the settings and model
files (`config.py`, `models.py`) come without them (`sfv --help`, `sfv models fetch`).
"""
from services.pose.config import PoseConfig
from services.pose.models import PoseModelFiles, default_models_dir, fetch_models, resolve_model_files
from services.pose.track import KEYPOINT_NAMES, PoseTrack

__all__ = ["PoseConfig", "PoseModelFiles", "PoseTrack", "KEYPOINT_NAMES", "default_models_dir", "estimate_video",
           "fetch_models", "resolve_model_files"]


def __getattr__(name: str):
    if name == "estimate_video":
        from services.pose.pipeline import estimate_video

        return estimate_video
    raise AttributeError(f"module 'services.pose' has no attribute {name!r}")
