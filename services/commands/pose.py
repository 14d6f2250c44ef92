"""`sfv pose VIDEO --out TRACK.npz`: per-frame BlazePose 2D + 3D landmarks of a video."""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from learner.errors import SfvError
from services.pose import PoseConfig, estimate_video
from services.pose.models import MODELS_ENV


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("pose", help="estimate the actor's pose in every frame of a video (Ray tasks)")
    parser.add_argument("video", type=Path, help="input video file")
    parser.add_argument("--out", type=Path, required=True, help="output pose track (.npz)")
    parser.add_argument("--pose-models", metavar="DIR", default=None,
                        help="directory with pose_detection.tflite + pose_landmark_full.tflite "
                             f"(default ${MODELS_ENV} or the `sfv models fetch` cache)")
    parser.add_argument("--landmark-model", metavar="FILE", default=None,
                        help="landmark model to use instead of the directory's (.tflite or .onnx)")
    parser.add_argument("--chunk-frames", type=int, default=PoseConfig().chunk_frames,
                        help="frames per Ray task")
    parser.add_argument("--serial", action="store_true", help="run in this process instead of as Ray tasks")
    parser.set_defaults(handler=run_pose)


def run_pose(args: argparse.Namespace) -> int:
    if args.chunk_frames < 1:
        raise SfvError(f"--chunk-frames must be >= 1, got {args.chunk_frames}")
    if args.out.suffix != ".npz":
        raise SfvError(f"{args.out}: output must be a .npz file")
    started = time.perf_counter()
    track = estimate_video(args.video, models_dir=args.pose_models, use_ray=not args.serial,
                           chunk_frames=args.chunk_frames, landmark_model=args.landmark_model)
    track.save(args.out)
    elapsed = time.perf_counter() - started
    print(f"{args.video}: {len(track)} frames, person in {int(track.valid.sum())}, "
          f"{track.filled_frames} filled by interpolation, {len(track) / elapsed:.1f} frames/s -> {args.out}")
    return 0
