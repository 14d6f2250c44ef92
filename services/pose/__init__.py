"""Per-frame human pose estimation from video (MediaPipe BlazePose "full"), as Ray tasks.

    track = estimate_video("clip.mp4", use_ray=True)   # -> PoseTrack
    track.save("clip_pose.npz")
"""
from services.pose.config import PoseConfig
from services.pose.models import PoseModelFiles, default_models_dir, fetch_models, resolve_model_files
from services.pose.pipeline import estimate_video
from services.pose.track import KEYPOINT_NAMES, PoseTrack

__all__ = ["PoseConfig", "PoseModelFiles", "PoseTrack", "KEYPOINT_NAMES", "default_models_dir", "estimate_video",
           "fetch_models", "resolve_model_files"]
