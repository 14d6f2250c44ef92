"""`sfv task`: task policies that reuse a motor module (NPMP 004 §3.4), or from scratch.

    sfv task go-to|push-box --module MODULE --out RUN [--action latent|joint] [--samples N] [--resume]
    sfv task eval RUN [--episodes 32] [--seed K]        (one JSON object)
    sfv task render RUN --video OUT.mp4 [--episodes 2]

`--action latent` trains a policy that outputs z for the module's frozen decoder; `--action
joint` trains absolute PD targets from scratch (no module needed). The run directory is a
training run's: config.json, metrics.jsonl (success_rate, time_to_target_s per iteration),
TensorBoard events, checkpoints, learning_curve.png. `services/tasks/evaluation.py` defines
every eval figure.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import logging

TASK_NAMES = {"go-to": "go_to", "push-box": "push_box"}
SAFE_ON_RESUME = ("samples", "workers", "envs_per_worker", "runner", "torch_threads", "ray_address")


HELP = "train, evaluate or render a task policy on a motor module (go-to, push-box)"  # the one line `sfv --help` lists (without importing the command)


def register(sub) -> None:
    p = sub.add_parser("task", help=HELP,
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("what", choices=(*TASK_NAMES, "eval", "render"), help="a task to train, or eval / render a run")
    p.add_argument("run", nargs="?", default=None, help="run directory (eval, render)")
    p.add_argument("--module", default=None, help="motor module directory (sfv distill's output); needed for --action latent")
    p.add_argument("--out", default=None, help="run directory to train into")
    p.add_argument("--action", choices=("latent", "joint"), default="latent", help="latent (z for the frozen decoder) or joint (PD targets from scratch)")
    p.add_argument("--samples", type=int, default=None, help="environment steps to train for (default 1000000)")
    p.add_argument("--workers", type=int, default=None, help="rollout workers (default 2)")
    p.add_argument("--envs-per-worker", type=int, default=None, help="envs per worker (default 16)")
    p.add_argument("--runner", choices=("ray", "in_process", "processes"), default=None, help="how workers run (default ray)")
    p.add_argument("--seed", type=int, default=None, help="base seed (train); episode seed (eval, render)")
    p.add_argument("--torch-threads", type=int, default=None, help="learner torch threads (0: every core)")
    p.add_argument("--latent-scale", type=float, default=None, help="z = this x the policy's [-1, 1] action (default 1)")
    p.add_argument("--horizon-s", type=float, default=None, help="episode length in seconds (default 10)")
    p.add_argument("--batch-size", type=int, default=None, help="samples per PPO iteration (default 4096)")
    p.add_argument("--resume", action="store_true", help="continue the run in --out from its newest checkpoint")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--episodes", type=int, default=None, help="eval: episodes (default 32); render: episodes filmed (default 2)")
    p.add_argument("--video", default=None, help="render: the MP4 to write")
    p.set_defaults(handler=run)


def build_config(args):
    from pathlib import Path

    from learner.errors import SfvError
    from services.tasks.config import TaskConfig, task_ppo
    from services.training.run_dir import CONFIG_FILE

    if not args.out:
        raise SfvError(f"sfv task {args.what}: --out is required (the run directory)")
    given = {k: getattr(args, k) for k in ("samples", "workers", "envs_per_worker", "runner", "seed", "torch_threads")
             if getattr(args, k) is not None}
    env_given = {k: getattr(args, k) for k in ("latent_scale", "horizon_s") if getattr(args, k) is not None}
    saved = Path(args.out) / CONFIG_FILE
    if args.resume and saved.is_file():
        config = TaskConfig.from_dict(json.loads(saved.read_text()))
        refused = [k for k in given if k not in SAFE_ON_RESUME] + list(env_given) + (["batch_size"] if args.batch_size else [])
        if TASK_NAMES[args.what] != config.env.task or args.action != config.env.action:
            refused.append(f"task/action ({args.what}, {args.action} vs the run's {config.env.task}, {config.env.action})")
        if refused:
            raise SfvError(f"sfv task --resume: {', '.join(refused)} cannot change mid-run ({saved})")
        return dataclasses.replace(config, **given)
    env = dict(task=TASK_NAMES[args.what], action=args.action, module=args.module, **env_given)
    from actors.envs.tasks.config import TaskEnvConfig

    ppo = task_ppo(args.action)
    if args.batch_size is not None:
        ppo.batch_size = args.batch_size
    return TaskConfig(out=str(args.out), env=TaskEnvConfig(**env), ppo=ppo, **given)


def _train(args) -> int:
    from services.tasks.driver import TaskTrainer

    config = build_config(args)
    config.validate()
    with TaskTrainer(config, resume=args.resume, progress=not args.quiet) as trainer:
        record = trainer.run()
    keys = ("iteration", "samples", "success_rate", "time_to_target_s", "fall_rate", "overall_samples_per_s")
    print(json.dumps({"run": str(config.out), **{k: record.get(k) for k in keys}}))
    return 0


def _evaluate(args) -> int:
    from learner.errors import SfvError
    from services.tasks.evaluation import evaluate_task
    from services.tasks.run_dir import load_task_run

    if not args.run:
        raise SfvError("sfv task eval: give the run directory")
    config, weights = load_task_run(args.run)
    episodes = 32 if args.episodes is None else args.episodes
    if episodes <= 0:
        raise SfvError(f"sfv task eval: --episodes must be positive, got {episodes}")
    print(json.dumps({"run": args.run, "task": config.env.task, "action": config.env.action,
                      **evaluate_task(config.env, weights, episodes, args.seed or 0)}))
    return 0


def _render(args) -> int:
    from learner.errors import SfvError
    from services.tasks.run_dir import load_task_run
    from services.tasks.video import render_task

    if not args.run or not args.video:
        raise SfvError("sfv task render: give the run directory and --video OUT.mp4")
    config, weights = load_task_run(args.run)
    episodes = 2 if args.episodes is None else args.episodes
    if episodes <= 0:
        raise SfvError(f"sfv task render: --episodes must be positive, got {episodes}")
    print(json.dumps(render_task(config.env, weights, args.video, episodes, args.seed or 0)))
    return 0


def run(args) -> int:
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    if args.what == "eval":
        return _evaluate(args)
    if args.what == "render":
        return _render(args)
    return _train(args)
