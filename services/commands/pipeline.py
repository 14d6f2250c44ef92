"""`sfv pipeline VIDEO --out DIR`: video -> pose (Ray tasks) -> reconstruction (a Ray task) -> training.

One Ray job graph on one Ray session: the pose tasks' track feeds the reconstruction task,
whose motion (written to DIR/motion.npz) the training driver imitates with its rollout
actors (run directory DIR/train).

`--camera moving [--scene boxes.yaml]` (002 §5-6): the motion is written root-free, then
`services/scene_fit` trains its windows' policies in 002's tracking mode (each window a run
directory DIR/windows/w<n>/train with Ray rollout actors), fits the scene by SLSQP and rolls the
policies out in it: DIR/simulated.npz, simulated.bvh, scene_fitted.yaml, scene_fit.json and
simulated.mp4 (the simulation beside the video). `_moving_pipeline.py` has that path.
"""
from __future__ import annotations

import json
from pathlib import Path

from services.training.config import INIT_MODES, TrainConfig

TRAIN_DEFAULTS = TrainConfig()  # the pipeline's training flags take `sfv train`'s defaults


def register(sub) -> None:
    p = sub.add_parser("pipeline", help="reconstruct a motion from a video, then train a controller for it")
    p.add_argument("video", type=Path, help="input video of one person")
    p.add_argument("--out", type=Path, required=True, help="output directory: track.npz, motion.npz, train/")
    p.add_argument("--pose-models", default=None, help="BlazePose model directory (default: `sfv models fetch` cache)")
    p.add_argument("--iterations", type=int, default=None, help="reconstruction optimiser steps")
    p.add_argument("--workers", type=int, default=TRAIN_DEFAULTS.workers, help="rollout workers")
    p.add_argument("--envs-per-worker", type=int, default=TRAIN_DEFAULTS.envs_per_worker, help="envs per worker")
    p.add_argument("--init", choices=INIT_MODES, default=TRAIN_DEFAULTS.init, help="initial state distribution")
    p.add_argument("--samples", type=int, default=TRAIN_DEFAULTS.samples, help="training samples")
    p.add_argument("--batch-size", type=int, default=None, help=f"samples per PPO iteration (default {TRAIN_DEFAULTS.ppo.batch_size})")
    p.add_argument("--ray-address", default=None, help="join a Ray cluster; local Ray when absent")
    p.add_argument("--seed", type=int, default=TRAIN_DEFAULTS.seed, help="base seed of training")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--camera", choices=("static", "moving"), default="static",
                   help="static: SFV's root path from the image (default); moving: root-free motion, 002's tracking, "
                        "windows, scene fit and a final rollout (samples per window: --samples)")
    p.add_argument("--scene", type=Path, default=None, help="with --camera moving: the boxes' scene file (YAML) whose "
                   "positions and heights are fitted within their domains")
    p.add_argument("--resume", action="store_true", help="with --camera moving: continue an interrupted run in --out "
                   "(its motion.npz kept, finished windows kept, the window in progress from its checkpoint)")
    p.set_defaults(handler=run)


def run(args) -> int:
    if args.camera == "moving":
        from services.commands._moving_pipeline import run_moving

        return run_moving(args)
    from learner.errors import SfvError

    if args.scene is not None or args.resume:
        raise SfvError(f"{'--scene' if args.scene is not None else '--resume'} needs --camera moving")
    return run_static(args)


def run_static(args) -> int:
    import dataclasses

    import ray

    from actors.motion.formats.io import save_motion
    from learner.errors import SfvError
    from services.pose import estimate_video
    from services.pose.video import probe_video
    from services.ray_session import connect_ray
    from services.reconstruction import ReconstructionConfig, reconstruct_on_ray
    from services.training.config import TrainConfig
    from services.training.driver import Trainer

    probe_video(args.video)  # missing file / not a video / no frames: one-line error before any work
    out: Path = args.out
    if (out / "motion.npz").exists():
        raise SfvError(f"{out}: holds a pipeline run already; choose another --out")
    out.mkdir(parents=True, exist_ok=True)
    config = ReconstructionConfig()
    if args.iterations is not None:
        config = dataclasses.replace(config, iterations=args.iterations)
    started_ray = connect_ray(args.ray_address, log_to_driver=False)
    try:
        track = estimate_video(args.video, models_dir=args.pose_models, use_ray=True)
        track.save(out / "track.npz")
        motion = reconstruct_on_ray(track, config, args.video.stem)
        motion_path = save_motion(motion, out / "motion.npz")
        train = TrainConfig(motion=str(motion_path), out=str(out / "train"), workers=args.workers,
                            envs_per_worker=args.envs_per_worker, init=args.init, samples=args.samples,
                            seed=args.seed, ray_address=args.ray_address)
        if args.batch_size:
            train.ppo.batch_size = args.batch_size
            train.ppo.minibatch_size = min(train.ppo.minibatch_size, args.batch_size)
        record = Trainer(train, progress=not args.quiet).run()
    finally:
        if started_ray:
            ray.shutdown()
    print(json.dumps({"motion": str(motion_path), "frames": motion.num_frames, "run": train.out,
                      "samples": record.get("samples"), "normalized_return": record.get("normalized_return")}))
    return 0
