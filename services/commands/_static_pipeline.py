"""`sfv pipeline` with a static camera (`pipeline.py` registers the command): the pose tasks and the
reconstruction task, the helped training, the controller against the video, then the body-alone stage
where the helped controller needs its help (`services/pipeline/body_alone.py`). `--resume` continues a
stopped run stage by stage; `--finish-only` plays the trained controllers against the video again."""
from __future__ import annotations

import json
from pathlib import Path


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
        summary = stage_summary(False, "the body-alone stage: needed, not trained (--finish-only plays what is "
                                       "trained; --resume trains it)" if needed else line)
    report = record_stage(out / "report.json", summary)
    print(report["controller"])
    return report


def _stage_config(args, motion: Path, run_dir: Path, resume: bool, residual_force: float | None = None):
    """One training's TrainConfig: the pipeline's defaults and the flags given; with --resume and a run
    that has a checkpoint there, that run's saved settings (the flags given follow `sfv train --resume`)."""
    from services.commands._pipeline_settings import STATIC_DEFAULTS, train_config
    from services.training.run_dir import CONFIG_FILE, checkpoint_files

    saved = None
    if resume and (run_dir / CONFIG_FILE).is_file() and checkpoint_files(run_dir):  # `_train` reads the checkpoint
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


def _train_while_falling(args, out: Path, motion_path: Path, config, report: dict, first: int, cap: int, what: str,
                         flag: str):
    """While `report` (the controller of `config` against the video) falls from the first frame (or topples at
    the clip's end), train on
    from the checkpoint by `first` / 2 samples, up to `cap`, and play it again (`further_samples`).
    Returns the last (config, report)."""
    import dataclasses

    from services.pipeline.body_alone import ending, further_samples
    from services.training.run_dir import trained_samples

    while (more := further_samples(report, trained_samples(config.out) or 0, first, cap)) is not None:
        print(f"{what}: its controller {ending(report)}; training on to {more} samples ({flag} {cap})")
        config = dataclasses.replace(config, samples=more)
        _train(config, progress=not args.quiet)
        report = _finish(args, out, motion_path, Path(config.out))
    return config, report


def _body_alone_stage(args, out: Path, helped: dict, resume: bool, first: int) -> dict:
    """The second stage (`services/pipeline/body_alone.py`) where the helped controller needs its help,
    `first` samples, then on while it falls; DIR/report.json's `body_alone` and `controller` either way."""
    from services.pipeline.body_alone import ALONE_DIR, helped_reference, max_samples, record_stage, stage_decision, stage_summary
    from services.training.run_dir import trained_samples

    needed, line = stage_decision(helped, args.body_alone)
    print(line)
    summary = stage_summary(False, line)
    if needed:
        alone = out / ALONE_DIR
        motion_path = alone / "motion.npz"
        if not (resume and motion_path.is_file()):
            motion_path = helped_reference(out, alone)
        config = _stage_config(args, motion_path, alone / "train", resume, residual_force=0.0)  # the body alone
        cap = max_samples(first, args.body_alone_max_samples, clip_seconds=helped.get("clip_seconds", 0.0))
        trained = _train(config, progress=not args.quiet)
        if trained or not (alone / "report.json").is_file():
            report = _finish(args, alone, motion_path, alone / "train")
        else:
            report = json.loads((alone / "report.json").read_text())
        config, report = _train_while_falling(args, alone, motion_path, config, report, first, cap,
                                              "the body-alone stage", "--body-alone-max-samples")
        summary = stage_summary(True, line, report, samples=trained_samples(config.out))
    report = record_stage(out / "report.json", summary)
    print(report["controller"])
    return report


def run_static(args) -> int:
    import ray

    from learner.errors import SfvError
    from services.commands._person_args import frame_range, person_choice
    from services.commands._pipeline_settings import STATIC_DEFAULTS, train_config
    from services.console import attach_log_file
    from services.pipeline.body_alone import max_samples
    from services.pose.video import probe_video
    from services.ray_session import connect_ray
    from services.training.run_dir import trained_samples

    out: Path = args.out
    train = train_config(args, str(out / "motion.npz"), str(out / "train"), STATIC_DEFAULTS)  # a bad setting: one line before any work
    budget = train.samples
    helped_cap = max_samples(budget, args.helped_max_samples, "--helped-max-samples")  # a cap below the budget: one line before any work
    max_samples(budget, args.body_alone_max_samples)
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
        more_before = trained_samples(train.out)
        helped_cap = max_samples(budget, args.helped_max_samples, "--helped-max-samples", helped.get("clip_seconds", 0.0))
        train, helped = _train_while_falling(args, out, motion_path, train, helped, budget, helped_cap,
                                             "the first controller (with its help)", "--helped-max-samples")
        trained = trained or trained_samples(train.out) != more_before
        report = _body_alone_stage(args, out, helped, resume and not trained, budget)  # a retrained helper: a new rollout
    finally:
        if started_ray:
            ray.shutdown()
    print(json.dumps({"motion": str(motion_path), "frames": report.get("frames"), "run": train.out,
                      "samples": train.samples, "first_frame": _summary(report), "controller": report["controller"]}))
    return 0
