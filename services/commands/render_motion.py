"""`sfv render-motion MOTION --video VIDEO --out FILE.mp4`: the video with its keypoints beside
the reconstructed humanoid, rendered by MuJoCo from the estimated camera."""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from learner.errors import SfvError


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("render-motion", help="render a reconstructed motion beside its video (MP4)")
    parser.add_argument("motion", help="motion file made by `sfv reconstruct` (.npz)")
    parser.add_argument("--video", type=Path, required=True, help="the video the motion was reconstructed from")
    parser.add_argument("--out", type=Path, required=True, help="output video (.mp4)")
    parser.add_argument("--height", type=int, default=480, help="height in pixels of each half of the output")
    parser.set_defaults(handler=run_render_motion)


def run_render_motion(args: argparse.Namespace) -> int:
    from actors.motion_io import load_motion
    from services.reconstruction.render import render_motion_video

    if args.out.suffix.lower() != ".mp4":
        raise SfvError(f"{args.out}: output must be an .mp4 file")
    if not 16 <= args.height <= 2160:
        raise SfvError(f"--height must be between 16 and 2160, got {args.height}")
    if not args.out.parent.is_dir():
        raise SfvError(f"{args.out}: directory {args.out.parent} does not exist")
    started = time.perf_counter()
    motion = load_motion(args.motion)
    frames = render_motion_video(motion, args.video, args.out, args.height, source=str(args.motion))
    print(f"{args.motion}: {frames} frames rendered beside {args.video} in {time.perf_counter() - started:.1f} s -> {args.out}")
    return 0
