"""`sfv pipeline VIDEO --out DIR`: video -> pose (Ray tasks) -> reconstruction (a Ray task) -> training.

One Ray job graph on one Ray session: the pose tasks' track feeds the reconstruction task,
whose motion (written to DIR/motion.npz by `sfv reconstruct`'s own path, `contacts/video_motion.py`:
the learned foot contacts it was fitted to, video_start_frame and the video's other extras)
the training driver imitates with its rollout actors (run directory DIR/train). Then the controller is played against the video
(`services/pipeline/finish.py`): its best checkpoint from the clip's first frame for the clip's
length, written as DIR/simulated.npz, simulated.bvh, video.mp4 (video | reference | simulation),
overlay_strip.png (the simulation over the video through the reconstruction's camera) and
report.json (fall, return, joint error, foot skating, penetration, reprojection error).
Where that controller needs its residual root force (it completes the clip, and falls with the help
at zero), a second training makes the body alone follow its rollout, into DIR/alone with the same
files (`services/pipeline/body_alone.py`; `--body-alone auto|always|off`); DIR/report.json's
`controller` line says which controller the pipeline gives and how it ends without help.
`--finish-only` plays the controllers against the video again on a finished DIR (another
`--checkpoint`); `--resume` continues an interrupted DIR where it stopped.

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
                             "[--scene BOXES.yaml] [--resume] [--body-alone auto|always|off] "
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
    p.add_argument("--resume", action="store_true",
                   help="continue an interrupted run in --out: its motion.npz kept, a training that stopped part way "
                        "from its checkpoint (with its saved settings), a finished one kept; with --camera moving, "
                        "finished windows kept")
    p.add_argument("--body-alone", choices=("auto", "always", "off"), default=None,
                   help="static camera: a second training of the body alone (no residual root force) on the helped "
                        "controller's rollout, into DIR/alone (services/pipeline/body_alone.py). auto (default): "
                        "when the helped controller completes the clip but falls without its help; always: also when "
                        "it does not fall; off: never")
    p.add_argument("--checkpoint", choices=("best", "latest"), default="best",
                   help="the checkpoint played against the video: best (best.pt, the best periodic evaluation; the "
                        "newest when the run has none) or latest")
    p.add_argument("--finish-only", action="store_true",
                   help="static camera: only play DIR/train's controller (and DIR/alone/train's, where there is one) "
                        "against the video again (DIR/motion.npz and DIR/train from an earlier run), rewriting "
                        "simulated.npz, simulated.bvh, video.mp4, overlay_strip.png and report.json")
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

        chosen = [f for f, v in (("--person", args.person), ("--person-at", args.person_at), ("--frames", args.frames),
                                 ("--body-alone", args.body_alone)) if v is not None]
        if chosen:
            from learner.errors import SfvError

            raise SfvError(f"{chosen[0]} is for --camera static (the moving path follows the default subject)")

        return run_moving(args)
    from learner.errors import SfvError

    if args.scene is not None:
        raise SfvError("--scene needs --camera moving")
    args.body_alone = args.body_alone or "auto"
    if args.finish_only and args.resume:
        raise SfvError("--finish-only and --resume: choose one (--resume finishes what it trains)")
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
    report = _finish_body_alone(args, out, report)
    print(json.dumps({"motion": str(motion_path), "run": str(run_dir), **_summary(report)}))
    return 0


def _finish_body_alone(args, out: Path, helped: dict) -> dict:
    """--finish-only: the body-alone controller (DIR/alone) against the video again, where a run trained
    one; DIR/report.json's `body_alone` and `controller` say which controller the pipeline gives."""
    from services.pipeline.body_alone import ALONE_DIR, record_stage, stage_decision, stage_summary
    from services.training.run_dir import CONFIG_FILE

    alone = out / ALONE_DIR
    if (alone / "train" / CONFIG_FILE).is_file() and (alone / "motion.npz").is_file():
        summary = stage_summary(True, f"the body-alone stage: {ALONE_DIR}/ finished again",
                                _finish(args, alone, alone / "motion.npz", alone / "train"))
    else:
        needed, line = stage_decision(helped, args.body_alone)
        summary = stage_summary(False, line.split(" (")[0] + ": not trained (--finish-only; --resume trains it)"
                                if needed else line)
    report = record_stage(out / "report.json", summary)
    print(report["controller"])
    return report


def _stage_config(args, motion: Path, run_dir: Path, resume: bool, residual_force: float | None = None):
    """One training's TrainConfig: the pipeline's defaults and the flags given; with --resume and a run
    that has a checkpoint there, that run's saved settings (the flags given follow `sfv train --resume`)."""
    from services.commands._pipeline_settings import STATIC_DEFAULTS, train_config
    from services.training.run_dir import CONFIG_FILE, trained_samples

    saved = None
    if resume and (run_dir / CONFIG_FILE).is_file() and trained_samples(run_dir) is not None:
        saved = json.loads((run_dir / CONFIG_FILE).read_text())
    config = train_config(args, str(motion), str(run_dir), STATIC_DEFAULTS, saved=saved)
    if residual_force is not None:
        import dataclasses

        config.env = dataclasses.replace(config.env, residual_force=residual_force)
        config.validate()
    return config


def _train(config, progress: bool) -> bool:
    """Train `config` into its run directory, continuing a run that stopped part way; a run that
    reached its samples is kept as it is. Returns whether anything was trained."""
    from services.training.driver import Trainer
    from services.training.run_dir import trained_samples

    done = trained_samples(config.out)
    if done is not None and done >= config.samples:
        print(f"training: {config.out} holds its {done} samples already (kept)")
        return False
    Trainer(config, resume=done is not None, progress=progress).run()
    return True


def _reconstruct(args, out: Path) -> Path:
    """Pose tasks, then the reconstruction task: DIR/track.npz and DIR/motion.npz."""
    import dataclasses

    from actors.motion.formats.io import save_motion
    from services.commands._person_args import frame_range, person_choice
    from services.contacts.video_motion import video_motion
    from services.pose import estimate_video
    from services.reconstruction import ReconstructionConfig

    config = ReconstructionConfig()
    if args.iterations is not None:
        config = dataclasses.replace(config, iterations=args.iterations)
    track = estimate_video(args.video, models_dir=args.pose_models, use_ray=True, choice=person_choice(args),
                           frames=frame_range(args), say=print)
    track.save(out / "track.npz")
    made = video_motion(track, config, args.video.stem, "static", str(args.video), say=print)
    print(made.check)
    return save_motion(made.motion, out / "motion.npz")


def _body_alone_stage(args, out: Path, helped: dict, resume: bool) -> dict:
    """The second stage (`services/pipeline/body_alone.py`) where the helped controller needs its help;
    DIR/report.json's `body_alone` and `controller` either way."""
    from services.pipeline.body_alone import ALONE_DIR, helped_reference, record_stage, stage_decision, stage_summary

    needed, line = stage_decision(helped, args.body_alone)
    print(line)
    summary = stage_summary(False, line)
    if needed:
        alone = out / ALONE_DIR
        motion_path = alone / "motion.npz"
        if not (resume and motion_path.is_file()):
            motion_path = helped_reference(out, alone)
        config = _stage_config(args, motion_path, alone / "train", resume, residual_force=0.0)  # the body alone
        trained = _train(config, progress=not args.quiet)
        if trained or not (alone / "report.json").is_file():
            report = _finish(args, alone, motion_path, alone / "train")
        else:
            report = json.loads((alone / "report.json").read_text())
        summary = stage_summary(True, line, report)
    report = record_stage(out / "report.json", summary)
    print(report["controller"])
    return report


def run_static(args) -> int:
    import ray

    from learner.errors import SfvError
    from services.commands._person_args import frame_range, person_choice
    from services.commands._pipeline_settings import STATIC_DEFAULTS, train_config
    from services.console import attach_log_file
    from services.pose.video import probe_video
    from services.ray_session import connect_ray

    out: Path = args.out
    train = train_config(args, str(out / "motion.npz"), str(out / "train"), STATIC_DEFAULTS)  # a bad setting: one line before any work
    person_choice(args), frame_range(args)  # a bad --person / --frames: one line before any work
    probe_video(args.video)  # missing file / not a video / no frames: one-line error before any work
    resume = args.resume and (out / "motion.npz").is_file()
    if (out / "motion.npz").exists() and not resume:
        raise SfvError(f"{out}: holds a pipeline run already; choose another --out (--resume continues it, "
                       "--finish-only plays its controller against the video again)")
    out.mkdir(parents=True, exist_ok=True)
    attach_log_file(out)  # library output (Ray, gRPC, warnings) goes to DIR/sfv.log
    started_ray = False if resume else connect_ray(train.ray_address)  # the pose tasks; the trainer joins it (or starts its own)
    try:
        if resume:
            motion_path = out / "motion.npz"
            print(f"reconstruction: {motion_path} (kept)")
        else:
            motion_path = _reconstruct(args, out)
        train = _stage_config(args, motion_path, out / "train", resume)
        trained = _train(train, progress=not args.quiet)
        if trained or not (out / "report.json").is_file():
            helped = _finish(args, out, motion_path, Path(train.out))
        else:
            helped = json.loads((out / "report.json").read_text())
        report = _body_alone_stage(args, out, helped, resume and not trained)  # a retrained helper: a new rollout
    finally:
        if started_ray:
            ray.shutdown()
    print(json.dumps({"motion": str(motion_path), "frames": report.get("frames"), "run": train.out,
                      "samples": train.samples, "first_frame": _summary(report), "controller": report["controller"]}))
    return 0
