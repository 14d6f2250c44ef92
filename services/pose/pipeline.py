"""Video file -> PoseTrack: split into frame chunks, estimate each (serially or as Ray
tasks, same code), stitch in order, fill the frames without a person."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from learner.errors import SfvError
from services.pose.config import PoseConfig
from services.pose.estimator import ChunkResult, FramePoseEstimator, estimate_chunk
from services.pose.models import resolve_model_files
from services.pose.track import PoseTrack, fill_gaps
from services.pose.video import VideoInfo, probe_video


def chunk_ranges(frame_count: int, chunk_frames: int) -> list[tuple[int, int]]:
    """[(start, stop), ...] covering 0..frame_count in chunks of at most chunk_frames."""
    if chunk_frames < 1:
        raise SfvError(f"chunk_frames must be >= 1, got {chunk_frames}")
    return [(start, min(start + chunk_frames, frame_count)) for start in range(0, frame_count, chunk_frames)]


def estimate_video(path: str | Path, models_dir: str | Path | None = None, use_ray: bool = False,
                   chunk_frames: int | None = None, config: PoseConfig | None = None,
                   landmark_model: str | Path | None = None) -> PoseTrack:
    """Per-frame BlazePose on every frame of a video.

    models_dir: where pose_detection.tflite and the landmark model live (default
    $SFV_POSE_MODELS or the user cache filled by `sfv models fetch`); landmark_model: an
    explicit .tflite/.onnx landmark file. use_ray: run chunks as Ray tasks (starts a
    local Ray when none is running); chunk_frames: frames per chunk (config.chunk_frames).
    """
    config = config or PoseConfig()
    path = Path(path)
    info = probe_video(path)
    files = resolve_model_files(models_dir, landmark_model)
    FramePoseEstimator(files, config)  # load both models here so a bad file fails before any task starts
    ranges = chunk_ranges(info.frame_count, chunk_frames or config.chunk_frames)
    if use_ray:
        from services.pose.distributed import run_chunks_on_ray

        chunks = run_chunks_on_ray(path, ranges, files, config)
    else:
        chunks = [estimate_chunk(path, start, stop, files, config) for start, stop in ranges]
    return assemble_track(info, ranges, chunks)


def assemble_track(info: VideoInfo, ranges: list[tuple[int, int]], chunks: list[ChunkResult]) -> PoseTrack:
    """Concatenate chunks in order (stopping at the first one the file ended inside,
    since containers can over-report their frame count) and fill the gaps."""
    kept: list[ChunkResult] = []
    for (start, stop), chunk in zip(ranges, chunks, strict=True):
        kept.append(chunk)
        if len(chunk) < stop - start:
            break
    frames = sum(len(c) for c in kept)
    if frames == 0:
        raise SfvError(f"{info.path}: video has no decodable frames")
    valid = np.concatenate([c.valid for c in kept])
    if not valid.any():
        raise SfvError(f"{info.path}: no person detected in any of {frames} frames")
    return PoseTrack(
        fps=info.fps,
        image_size=(info.width, info.height),
        keypoints2d=fill_gaps(np.concatenate([c.keypoints2d for c in kept]), valid),
        confidence=np.concatenate([c.confidence for c in kept]),
        world3d=fill_gaps(np.concatenate([c.world3d for c in kept]), valid),
        valid=valid,
        presence=np.concatenate([c.presence for c in kept]),
        rotation_used=np.concatenate([c.rotation_used for c in kept]),
        filled_frames=int((~valid).sum()),
    )
