"""`sfv reconstruct VIDEO --out MOTION.npz`: video -> pose track (Ray tasks) -> motion (a Ray task)."""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from learner.errors import SfvError
from services.commands._person_args import add_person_arguments, frame_range, person_choice


HELP = "reconstruct a reference motion from a video (pose estimation + SFV motion reconstruction)"  # the one line `sfv --help` lists (without importing the command)


def register(subparsers: argparse._SubParsersAction) -> None:
    from services.reconstruction.config import ReconstructionConfig

    defaults = ReconstructionConfig()
    parser = subparsers.add_parser("reconstruct", help=HELP)
    parser.add_argument("video", type=Path, help="input video file")
    parser.add_argument("--out", type=Path, required=True, help="output motion (.npz; `sfv train --motion` reads it)")
    parser.add_argument("--pose-models", metavar="DIR", default=None,
                        help="directory with the BlazePose models (default $SFV_POSE_MODELS or the `sfv models fetch` cache)")
    parser.add_argument("--iterations", type=int, default=defaults.iterations, help="optimiser steps of the reconstruction")
    parser.add_argument("--track", type=Path, default=None,
                        help="use this pose track (from `sfv pose`) instead of estimating the poses again")
    parser.add_argument("--save-track", type=Path, default=None, help="also write the estimated pose track here (.npz)")
    parser.add_argument("--ray-address", default=None, help="join a Ray cluster ('auto' or host:port); local Ray when absent")
    parser.add_argument("--serial", action="store_true", help="run pose estimation and reconstruction in this process, without Ray")
    parser.add_argument("--camera", choices=("static", "moving", "auto"), default="auto",
                        help="static: the root path comes from image position and scale (SFV); moving: the camera "
                             "pans/tilts/zooms, so the motion is written root-free (joint rotations, root not to be "
                             "tracked); auto: decide from the background's motion (default)")
    add_person_arguments(parser)
    parser.set_defaults(handler=run_reconstruct)


def _check_args(args: argparse.Namespace) -> None:
    if args.out.suffix != ".npz":
        raise SfvError(f"{args.out}: output must be a .npz file")
    if args.save_track is not None and args.save_track.suffix != ".npz":
        raise SfvError(f"{args.save_track}: pose track must be a .npz file")
    if args.iterations < 0:
        raise SfvError(f"--iterations must be >= 0, got {args.iterations}")
    if args.track is not None and args.save_track is not None:
        raise SfvError("--track and --save-track exclude each other (the track already exists)")
    chosen = [flag for flag, value in (("--person", args.person), ("--person-at", args.person_at), ("--frames", args.frames))
              if value is not None]
    if args.track is not None and chosen:
        raise SfvError(f"--track and {chosen[0]} exclude each other (the track already follows one person)")


def run_reconstruct(args: argparse.Namespace) -> int:
    import dataclasses

    from actors.motion.formats.io import save_motion
    from services.contacts.video_motion import video_motion
    from services.pose import PoseTrack, estimate_video
    from services.pose.video import probe_video
    from services.ray_session import connect_ray
    from services.reconstruction import ReconstructionConfig

    _check_args(args)
    choice, frames = person_choice(args), frame_range(args)
    started = time.perf_counter()
    info = probe_video(args.video)  # missing file, not a video, no frames: one-line errors before any work
    config = dataclasses.replace(ReconstructionConfig(), iterations=args.iterations)
    use_ray = not args.serial
    ray_started = connect_ray(args.ray_address) if use_ray else False
    try:
        if args.track is not None:
            track = PoseTrack.load(args.track)
        else:
            track = estimate_video(args.video, models_dir=args.pose_models, use_ray=use_ray, choice=choice, frames=frames,
                                   say=print)
            if args.save_track is not None:
                track.save(args.save_track)
        made = video_motion(track, config, args.video.stem, args.camera, str(args.track or args.video), use_ray,
                            say=print)
    finally:
        if ray_started:
            import ray

            ray.shutdown()
    motion, track = made.motion, made.track
    if made.check:
        print(made.check)
    save_motion(motion, args.out)
    elapsed = time.perf_counter() - started
    flipped = int(motion.extras["label_flipped"].sum())
    print(f"{args.video}: {motion.num_frames} of {info.frame_count} frames (person {track.person_id}, from frame "
          f"{track.start_frame}, {track.filled_frames} not seen and interpolated), {flipped} left/right readings undone, "
          f"mean reprojection error {float(motion.extras['reprojection_error_px'].mean()):.1f} px, "
          f"{_camera_words(made.path, made.moving)}, {elapsed:.1f} s -> {args.out}")
    return 0


def _camera_words(path, moving: bool) -> str:
    untracked = f", background untracked in {path.untracked_frames} frames" if path is not None and path.untracked_frames else ""
    if not moving:
        return "static camera" + (" (camera motion not measured in this track)" if path is None else untracked)
    travel = "" if path is None else (f" (view moved {float(abs(path.offset_px).max()):.0f} px, "
                                      f"zoom x{float(path.total_zoom[-1]):.2f})")
    return f"moving camera{travel}{untracked}: root-free motion, its root path is not to be tracked"
