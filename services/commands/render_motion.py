"""`sfv render-motion MOTION --video VIDEO --out FILE.mp4`: the video with its keypoints beside
the reconstructed humanoid, rendered by MuJoCo from the estimated camera.

`sfv render-motion MOTION --source CLIP.bvh --out FILE.mp4`: the BVH's skeleton as a stick
figure beside the humanoid retargeted from it (`services/render/source_skeleton.py`).

`sfv render-motion CLIP_g1.npz --out FILE.mp4 [--source-motion CLIP]`: a robot motion (`sfv motion
convert CLIP --character g1`) beside its source humanoid (the file's `source`, or the clip
given), `services/render/robot_motion_video.py`."""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from learner.errors import SfvError


HELP = "render a reconstructed motion beside its video (MP4)"  # the one line `sfv --help` lists (without importing the command)


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("render-motion", help=HELP)
    parser.add_argument("motion", help="motion file made by `sfv reconstruct` (.npz)")
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--video", type=Path, help="the video the motion was reconstructed from")
    source.add_argument("--source", type=Path, help="the BVH the motion was retargeted from (drawn as a stick figure)")
    source.add_argument("--source-motion", default=None,
                        help="with a robot motion: the clip it was retargeted from (default: the file's `source`)")
    parser.add_argument("--rig", default="auto", help="with --source: the rig (auto, a preset or a map file), as for `sfv motion convert`")
    parser.add_argument("--out", type=Path, required=True, help="output video (.mp4)")
    parser.add_argument("--height", type=int, default=480, help="height in pixels of each half of the output")
    parser.set_defaults(handler=run_render_motion)


def run_render_motion(args: argparse.Namespace) -> int:
    from actors.motion.formats.io import load_motion
    from services.render.motion_video import render_motion_video

    if args.out.suffix.lower() != ".mp4":
        raise SfvError(f"{args.out}: output must be an .mp4 file")
    if not 16 <= args.height <= 2160:
        raise SfvError(f"--height must be between 16 and 2160, got {args.height}")
    if not args.out.parent.is_dir():
        raise SfvError(f"{args.out}: directory {args.out.parent} does not exist")
    started = time.perf_counter()
    from actors.motion.robot_motion import is_robot_motion

    if is_robot_motion(args.motion):
        return _render_robot_motion(args, started)
    if args.video is None and args.source is None:
        raise SfvError(f"{args.motion}: give --video (a reconstruction) or --source (a retargeted BVH)")
    if args.source_motion is not None:
        raise SfvError("--source-motion applies to a robot motion (`sfv motion convert CLIP --character g1`)")
    motion = load_motion(args.motion)
    if args.source is not None:
        from services.render.source_skeleton import render_source_video

        frames = render_source_video(motion, args.source, args.out, args.height - args.height % 2, args.rig)
        print(f"{args.motion}: {frames} frames rendered beside the source skeleton of {args.source} in "
              f"{time.perf_counter() - started:.1f} s -> {args.out}")
        return 0
    frames = render_motion_video(motion, args.video, args.out, args.height, source=str(args.motion))
    print(f"{args.motion}: {frames} frames rendered beside {args.video} in {time.perf_counter() - started:.1f} s -> {args.out}")
    return 0


def _render_robot_motion(args: argparse.Namespace, started: float) -> int:
    from actors.motion.formats.io import load_motion
    from actors.motion.robot_motion import load_robot_motion
    from services.render.robot_motion_video import render_robot_motion_video

    if args.video is not None or args.source is not None:
        raise SfvError(f"{args.motion}: a robot motion is drawn beside its source clip (--source-motion), not a video or BVH")
    robot = load_robot_motion(args.motion)
    source = load_motion(args.source_motion or robot.source)
    frames = render_robot_motion_video(robot, source, args.out, args.height - args.height % 2)
    print(f"{args.motion}: {frames} frames rendered beside its source {source.name} in "
          f"{time.perf_counter() - started:.1f} s -> {args.out}")
    return 0
