"""`sfv pipeline VIDEO --out DIR`: video -> pose (Ray tasks) -> reconstruction (a Ray task) -> training.

One Ray job graph on one Ray session: the pose tasks' track feeds the reconstruction task,
whose motion (written to DIR/motion.npz by `sfv reconstruct`'s own path, `contacts/video_motion.py`:
the learned foot contacts it was fitted to, video_start_frame and the video's other extras)
the training driver imitates with its rollout actors (run directory DIR/train). Then the controller is played against the video
(`services/pipeline/finish.py`): its best checkpoint from the clip's first frame for the clip's
length, written as DIR/simulated.npz, simulated.bvh, video.mp4 (video | reference | simulation),
overlay_strip.png (the simulation over the video through the reconstruction's camera) and
report.json (fall, return, joint error, foot skating, penetration, reprojection error).
`--finish-only` does that last step again on a finished DIR (another `--checkpoint`).

`--camera moving [--scene boxes.yaml]` (002 §5-6): the motion is written root-free, then
`services/scene_fit` trains its windows' policies in 002's tracking mode (each window a run
directory DIR/windows/w<n>/train with Ray rollout actors), fits the scene by SLSQP and rolls the
policies out in it: DIR/simulated.npz, simulated.bvh, scene_fitted.yaml, scene_fit.json and
simulated.mp4 (the simulation beside the video). `_moving_pipeline.py` has that path.
"""
from __future__ import annotations

import json
from pathlib import Path

HELP = "reconstruct a motion from a video, then train a controller for it"  # the one line `sfv --help` lists (without importing the command)


def register(sub) -> None:
    from services.commands._person_args import add_person_arguments
    from services.commands._pipeline_settings import PIPELINE_DEFAULT_TEXT, PIPELINE_SETS
    from services.training.flags import add_config_flags

    p = sub.add_parser("pipeline", help=HELP,
                       usage="sfv pipeline VIDEO --out DIR [--person ID | --person-at X,Y@FRAME] [--frames A:B] [--camera static|moving] "
                             "[--scene BOXES.yaml] [--resume] "
                             "[--checkpoint best|latest] [--finish-only] "
                             "[--config FILE.yaml] [training settings ...]  (sfv pipeline --help lists every setting)",
                       description="Reconstruct a motion from a video, then train a controller for it. The training "
                                   "settings are `sfv train`'s (the config dataclasses' fields, same defaults).")
    p.add_argument("video", type=Path, help="input video of one person")
    p.add_argument("--out", type=Path, required=True, help="output directory: track.npz, motion.npz, train/, then (static "
                   "camera) simulated.npz, simulated.bvh, video.mp4, overlay_strip.png, report.json")
    add_person_arguments(p)
    p.add_argument("--pose-models", default=None, help="BlazePose model directory (default: `sfv models fetch` cache)")
    p.add_argument("--iterations", type=int, default=None, help="reconstruction optimiser steps")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--camera", choices=("static", "moving"), default="static",
                   help="static: SFV's root path from the image (default); moving: root-free motion, 002's tracking, "
                        "windows, scene fit and a final rollout (samples per window: --samples)")
    p.add_argument("--scene", type=Path, default=None, help="with --camera moving: the boxes' scene file (YAML) whose "
                   "positions and heights are fitted within their domains")
    p.add_argument("--resume", action="store_true", help="with --camera moving: continue an interrupted run in --out "
                   "(its motion.npz kept, finished windows kept, the window in progress from its checkpoint)")
    p.add_argument("--checkpoint", choices=("best", "latest"), default="best",
                   help="the checkpoint played against the video: best (best.pt, the best periodic evaluation; the "
                        "newest when the run has none) or latest")
    p.add_argument("--finish-only", action="store_true",
                   help="static camera: only play DIR/train's controller against the video again (DIR/motion.npz and "
                        "DIR/train from an earlier run), rewriting simulated.npz, simulated.bvh, video.mp4, "
                        "overlay_strip.png and report.json")
    p.add_argument("--config", default=None, metavar="FILE.yaml",
                   help="training settings from a YAML file (the layout `sfv train --print-config` writes); flags given win")
    add_config_flags(p, skip=PIPELINE_SETS, title="training settings (`sfv train`'s; each a config field)",
                     default_text=PIPELINE_DEFAULT_TEXT)
    p.set_defaults(handler=run)


def run(args) -> int:
    if args.camera == "moving" and args.finish_only:
        from learner.errors import SfvError

        raise SfvError("--finish-only is for --camera static (the moving path writes its outputs itself; --resume continues it)")
    if args.camera == "moving":
        from services.commands._moving_pipeline import run_moving

        chosen = [f for f, v in (("--person", args.person), ("--person-at", args.person_at), ("--frames", args.frames))
                  if v is not None]
        if chosen:
            from learner.errors import SfvError

            raise SfvError(f"{chosen[0]} is for --camera static (the moving path follows the default subject)")

        return run_moving(args)
    from learner.errors import SfvError

    if args.scene is not None or args.resume:
        raise SfvError(f"{'--scene' if args.scene is not None else '--resume'} needs --camera moving")
    if args.finish_only:
        return run_finish_only(args)
    return run_static(args)


def _finish(args, out: Path, motion_path: Path, run_dir: Path) -> dict:
    """The controller against the video; one line per file written, then the report."""
    from services.pipeline.finish import finish_static_run

    return finish_static_run(out, args.video, motion_path, run_dir, checkpoint=args.checkpoint, progress=not args.quiet)


def _summary(report: dict) -> dict:
    return {key: report[key] for key in ("outcome", "fell", "fell_at_s", "normalized_return", "files")} | {
        "joint_position_error_m": report["joint_position_error_m"]["mean"],
        "reprojection_error_px": (report["reprojection_error_px"]["simulated"] or {}).get("mean")}


def run_finish_only(args) -> int:
    from learner.errors import SfvError
    from services.pose.video import probe_video
    from services.training.run_dir import CONFIG_FILE

    out: Path = args.out
    motion_path, run_dir = out / "motion.npz", out / "train"
    for path, what in ((motion_path, "motion.npz"), (run_dir / CONFIG_FILE, f"train/{CONFIG_FILE}")):
        if not path.is_file():
            raise SfvError(f"{out}: has no {what}; --finish-only needs a directory an earlier `sfv pipeline` wrote")
    probe_video(args.video)
    report = _finish(args, out, motion_path, run_dir)
    print(json.dumps({"motion": str(motion_path), "run": str(run_dir), **_summary(report)}))
    return 0


def run_static(args) -> int:
    import dataclasses

    import ray

    from actors.motion.formats.io import save_motion
    from learner.errors import SfvError
    from services.pose import estimate_video
    from services.commands._person_args import frame_range, person_choice
    from services.commands._pipeline_settings import STATIC_DEFAULTS, train_config
    from services.console import attach_log_file
    from services.pose.video import probe_video
    from services.ray_session import connect_ray
    from services.contacts.video_motion import video_motion
    from services.reconstruction import ReconstructionConfig
    from services.training.driver import Trainer

    out: Path = args.out
    train = train_config(args, str(out / "motion.npz"), str(out / "train"), STATIC_DEFAULTS)  # a bad setting: one line before any work
    choice, frames = person_choice(args), frame_range(args)
    probe_video(args.video)  # missing file / not a video / no frames: one-line error before any work
    if (out / "motion.npz").exists():
        raise SfvError(f"{out}: holds a pipeline run already; choose another --out (or --finish-only to play its "
                       "controller against the video again)")
    out.mkdir(parents=True, exist_ok=True)
    attach_log_file(out)  # library output (Ray, gRPC, warnings) goes to DIR/sfv.log
    config = ReconstructionConfig()
    if args.iterations is not None:
        config = dataclasses.replace(config, iterations=args.iterations)
    started_ray = connect_ray(train.ray_address)
    try:
        track = estimate_video(args.video, models_dir=args.pose_models, use_ray=True, choice=choice, frames=frames,
                               say=print)
        track.save(out / "track.npz")
        made = video_motion(track, config, args.video.stem, "static", str(args.video), say=print)
        print(made.check)
        motion = made.motion
        motion_path = save_motion(motion, out / "motion.npz")
        train.motion = str(motion_path)
        record = Trainer(train, progress=not args.quiet).run()
    finally:
        if started_ray:
            ray.shutdown()
    report = _finish(args, out, motion_path, Path(train.out))
    print(json.dumps({"motion": str(motion_path), "frames": motion.num_frames, "run": train.out,
                      "samples": record.get("samples"), "training_normalized_return": record.get("normalized_return"),
                      "first_frame": _summary(report)}))
    return 0
