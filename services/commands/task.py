"""`sfv task`: task policies that reuse a motor module (NPMP 004 §3.4), or from scratch.

    sfv task go-to|push-box --module MODULE --out RUN [--action latent|joint] [--slope 0.15] [--samples N] [--config F.yaml] [--resume]
    sfv task SPEC [--module MODULE] --out RUN            (a registered task spec: npmp-go-to-latent, ...)
    sfv task eval RUN [--episodes 32] [--seed K]        (one JSON object)
    sfv task render RUN --video OUT.mp4 [--episodes 2]
    sfv task heatmap RUN --out heatmap.png [--episodes 2]   (go-to success against the target's position, 004 Fig. 6B)

`--action latent` trains a policy that outputs z for the module's frozen decoder; `--action
joint` trains absolute PD targets from scratch (no module needed). `--slope G` puts the task on
an incline of grade G (SFV Fig. 8's push up and down a 15 % slope: `actors/arenas/slope.py`); its
eval splits success and falls by up, down and across. The run directory is a
training run's: config.json, metrics.jsonl (success_rate, time_to_target_s per iteration),
TensorBoard events, checkpoints, learning_curve.png. `services/tasks/evaluation.py` defines
every eval figure.
"""
from __future__ import annotations

import argparse
import json
import logging

TASK_NAMES = {"go-to": "go_to", "push-box": "push_box", "push-box-phased": "push_box_phased"}
SAFE_ON_RESUME = frozenset({"samples", "workers", "envs_per_worker", "runner", "torch_threads", "ray_address", "device",
                            "worker_timeout_s", "checkpoint_every", "keep_checkpoints", "plot_every", "plot_min_interval_s"})


HELP = "train, evaluate or render a task policy on a motor module (go-to, push-box, push-box-phased)"  # the one line `sfv --help` lists (without importing the command)


def task_schema():
    """`TaskConfig` as flags, YAML and resume rules (the shared mechanism of `services/training/flags.py`)."""
    from services.tasks.config import TaskConfig
    from services.training.flags import Alias, ConfigSchema

    aliases = (Alias("--module", ("env.module",)), Alias("--action", ("env.action",)),
               Alias("--latent-scale", ("env.latent_scale",)), Alias("--horizon-s", ("env.horizon_s",)),
               Alias("--batch-size", ("ppo.batch_size",)), Alias("--slope", ("env.slope",)))
    fixed = {"out", "env.task", "job_id", "curriculum_start_s", "curriculum_samples", "eval_every", "eval_episodes", "max_policy_lag"}
    return ConfigSchema(TaskConfig, "sfv task", aliases, SAFE_ON_RESUME, frozenset(fixed))


def register(sub) -> None:
    from services.training.flags import add_config_flags

    p = sub.add_parser("task", help=HELP,
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    from services.specs import specs_for

    p.add_argument("what", choices=(*TASK_NAMES, "eval", "render", "heatmap", *specs_for("task")),
                   help="a task to train, a registered task spec (npmp-go-to-latent, ...), or eval / render / heatmap a run")
    p.add_argument("run", nargs="?", default=None, help="run directory (eval, render)")
    p.add_argument("--out", default=None, help="run directory to train into; heatmap: the PNG to write (its figures beside it as .json)")
    p.add_argument("--config", default=None, metavar="FILE.yaml", help="settings from a YAML file (the run's config.json layout); flags given win")
    p.add_argument("--resume", action="store_true", help="continue the run in --out from its newest checkpoint")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--episodes", type=int, default=None, help="eval: episodes (default 32); render: episodes filmed (default 2); "
                   "heatmap: episodes per cell (default 2)")
    p.add_argument("--video", default=None, help="render: the MP4 to write")
    add_config_flags(p, title="settings (each a TaskConfig field; --seed is also eval's and render's episode seed)",
                     schema=task_schema())
    p.set_defaults(handler=run)


def _default_config(task: str, action: str) -> dict:
    """A fresh run's config: the task's env and the PPO settings of its action space."""
    from actors.envs.tasks.config import TaskEnvConfig
    from services.tasks.config import TaskConfig, task_ppo

    return TaskConfig(env=TaskEnvConfig(task=task, action=action), ppo=task_ppo(action)).to_dict()


def build_config(args):
    """The run's TaskConfig: defaults for its task and action space (or the saved config on
    --resume), then --config, then flags; unsafe changes on --resume are refused."""
    from pathlib import Path

    from learner.errors import SfvError
    from services.training.flags import given_settings, read_config_file, resolve
    from services.training.run_dir import CONFIG_FILE

    if not args.out:
        raise SfvError(f"sfv task {args.what}: --out is required (the run directory)")
    from services.specs import specs_for

    schema = task_schema()
    spec = specs_for("task").get(args.what)
    given = dict(spec.settings) if spec else {"env.task": TASK_NAMES[args.what]}
    flags = {path: f"spec {spec.name}: {path}" for path in given} if spec else {"env.task": f"the task ({args.what})"}
    if args.config is not None:
        from_file = read_config_file(args.config, schema)
        given.update(from_file)
        flags.update({path: f"{args.config}: {path}" for path in from_file})
    from_flags, flag_names = given_settings(args, schema)
    given.update(from_flags)
    flags.update(flag_names)
    saved = Path(args.out) / CONFIG_FILE
    resuming = args.resume and saved.is_file()
    base = json.loads(saved.read_text()) if resuming else _default_config(given["env.task"], given.get("env.action", "latent"))
    config = resolve(given, flags, base, resuming=resuming, schema=schema)
    config.out = str(args.out)
    return config


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
                      **evaluate_task(config.env, weights, episodes, getattr(args, "seed", 0))}))
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
    print(json.dumps(render_task(config.env, weights, args.video, episodes, getattr(args, "seed", 0))))
    return 0


def _heatmap(args) -> int:
    from pathlib import Path

    from learner.errors import SfvError
    from learner.policy import NumpyPolicy
    from services.tasks.heatmap import success_heatmap, write_heatmap
    from services.tasks.run_dir import load_task_run

    if not args.run or not args.out:
        raise SfvError("sfv task heatmap: give the run directory and --out HEATMAP.png")
    if Path(args.out).suffix.lower() != ".png":
        raise SfvError(f"sfv task heatmap: --out {args.out}: give a .png path")
    config, weights = load_task_run(args.run)
    per_cell = 2 if args.episodes is None else args.episodes
    record = success_heatmap(config.env, NumpyPolicy(weights, max_batch=256), episodes_per_cell=per_cell, seed=getattr(args, "seed", 0))
    write_heatmap(record | {"run": args.run, "action": config.env.action}, Path(args.out), f"{args.run} ({config.env.action})")
    print(json.dumps({"run": args.run, "out": args.out, "success_mean": record["success_mean"], "fall_rate_mean": record["fall_rate_mean"]}))
    return 0


def run(args) -> int:
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    if args.what == "heatmap":
        return _heatmap(args)
    if args.what == "eval":
        return _evaluate(args)
    if args.what == "render":
        return _render(args)
    return _train(args)
