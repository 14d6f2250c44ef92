"""`sfv train`: PPO imitation of one motion with rollout workers and an ASI server."""
from __future__ import annotations

import json
import logging

INIT_MODES = ("asi", "rsi", "fsi")  # services.training.config.INIT_MODES, repeated to keep `sfv` start-up light


def register(sub) -> None:
    p = sub.add_parser("train", help="train a controller that imitates a motion")
    p.add_argument("--motion", default="deepmimic:walk", help="motion name (deepmimic:walk) or file (.npz / DeepMimic .txt)")
    p.add_argument("--workers", type=int, default=2, help="rollout workers (Ray actors)")
    p.add_argument("--envs-per-worker", type=int, default=32, help="envs per worker, batched policy inference")
    p.add_argument("--init", choices=INIT_MODES, default="asi", help="initial state distribution")
    p.add_argument("--samples", type=int, default=200_000, help="total environment steps")
    p.add_argument("--out", required=True, help="run directory")
    p.add_argument("--ray-address", default=None, help="join a Ray cluster ('auto' or host:port); local Ray when absent")
    p.add_argument("--asi-address", default=None, help="host:port of an `sfv asi-server`; embedded when absent")
    p.add_argument("--asi-host", default="127.0.0.1",
                   help="interface the embedded ASI server binds; 127.0.0.1 serves workers on this node only, "
                        "on a multi-node Ray cluster give the head's cluster IP or use --asi-address")
    p.add_argument("--redis-url", default=None, help="Redis store for the embedded ASI server")
    p.add_argument("--asi-tls-ca", default=None, help="PEM root certificate: talk TLS to an `sfv asi-server --tls-cert`")
    p.add_argument("--asi-outage-s", type=float, default=30.0, help="seconds workers wait out an unreachable ASI server before training stops")
    p.add_argument("--worker-timeout-s", type=float, default=None,
                   help="kill and restart a rollout worker whose share takes longer (default 300)")
    p.add_argument("--resume", action="store_true", help="continue from the newest checkpoint in --out")
    p.add_argument("--seed", type=int, default=0, help="base seed (worker i: seed + i)")
    p.add_argument("--serial", action="store_true", help="run workers in this process without Ray")
    p.add_argument("--batch-size", type=int, default=None, help="samples per PPO iteration (default 4096, the paper's)")
    p.add_argument("--hidden", type=_layer_sizes, default=None, metavar="N,N",
                   help="hidden layer sizes of the policy and value MLPs (default 1024,512, the paper's)")
    p.add_argument("--epochs", type=_positive(int), default=None, help="PPO passes over each batch (default 1, DeepMimic's)")
    p.add_argument("--policy-lr", type=_positive(float), default=None, help="policy learning rate (default 5e-5, Adam)")
    p.add_argument("--torch-threads", type=_positive(int), default=None,
                   help="learner's torch threads (default: every core; workers wait while the learner updates)")
    p.add_argument("--physics-hz", type=float, default=None, help="physics rate (default 300)")
    p.add_argument("--no-early-termination", action="store_true", help="keep episodes going after a fall (rolls, getups)")
    p.add_argument("--ground-contact", type=_link_names, default=None, metavar="LINK,LINK",
                   help="links besides the feet allowed on the ground without a fall (default: the clip's DeepMimic setting; 'none': feet only)")
    p.add_argument("--reward", choices=("deepmimic", "sfv_paper"), default=None,
                   help="reward form (default deepmimic: weighted-mean joint errors, root term, centre-of-mass velocity; sfv_paper: the paper's sums)")
    p.add_argument("--action", choices=("exp_map", "axis_angle"), default=None, help="action parameterisation (default exp_map)")
    p.add_argument("--residual-scale", type=float, default=None,
                   help="residual PD targets: reference + this (rad) x action (default 0.5); 0 = absolute targets")
    p.add_argument("--reference-obs", type=_steps, default=None, metavar="K,K",
                   help="control steps ahead at which the policy observes the reference root (e.g. 1,15); 'none' for SFV's observation")
    p.add_argument("--asi-std-scale", type=_positive(float), default=None,
                   help="initial std of each ASI component as a multiple of the clip's per-dimension std (default 0.25; paper: 1)")
    p.add_argument("--state-space", choices=("rotvec", "qpos"), default=None,
                   help="coordinates ASI's Gaussians live in (default rotvec; qpos: SFV's raw qpos + qvel)")
    p.add_argument("--curriculum-start-s", type=float, default=None,
                   help="episode-length curriculum: first episodes capped at this many seconds, growing to the horizon over --curriculum-samples (default 0.5 s over 1 M; 0: off)")
    p.add_argument("--curriculum-samples", type=_positive(int), default=None, help="samples over which the curriculum reaches the horizon")
    p.add_argument("--no-root-sync", action="store_true", help="do not re-synchronise the reference root to the character each cycle")
    p.add_argument("--eval-every", type=int, default=None, help="samples between evaluations during training (default 500000; 0: never)")
    p.add_argument("--eval-episodes", type=int, default=None, help="episodes per evaluation during training (default 8)")
    p.add_argument("--asi-components", type=int, default=10, help="k, Gaussian components of the ASI distribution")
    p.add_argument("--asi-episodes-per-update", type=int, default=2000, help="episodes per ASI gradient step (paper: 2000)")
    p.add_argument("--checkpoint-every", type=int, default=None, help="iterations between checkpoints")
    p.add_argument("--device", default="cpu", help="torch device of the learner")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(handler=run)


def build_config(args):
    import dataclasses
    from pathlib import Path

    from learner.errors import SfvError
    from actors.humanoid import PhysicsConfig
    from services.training.run_dir import CONFIG_FILE
    from services.training.config import TrainConfig

    saved = Path(args.out) / CONFIG_FILE
    if args.resume and saved.exists():
        config = TrainConfig.from_dict(json.loads(saved.read_text()))
        config.samples = args.samples
        config.ray_address, config.asi_address, config.redis_url = args.ray_address, args.asi_address, args.redis_url
        config.serial, config.device = args.serial, args.device
        config.asi_tls_ca, config.asi_outage_s = args.asi_tls_ca, args.asi_outage_s
        if args.worker_timeout_s is not None:
            config.worker_timeout_s = args.worker_timeout_s
        return config
    config = TrainConfig(
        motion=args.motion, out=args.out, workers=args.workers, envs_per_worker=args.envs_per_worker,
        init=args.init, samples=args.samples, seed=args.seed, ray_address=args.ray_address,
        asi_address=args.asi_address, asi_host=args.asi_host, redis_url=args.redis_url, serial=args.serial, device=args.device,
        asi_tls_ca=args.asi_tls_ca, asi_outage_s=args.asi_outage_s,
        asi_components=args.asi_components, asi_episodes_per_update=args.asi_episodes_per_update,
    )
    if args.batch_size:
        config.ppo.batch_size = args.batch_size
        config.ppo.minibatch_size = min(config.ppo.minibatch_size, args.batch_size)
    if args.worker_timeout_s is not None:
        config.worker_timeout_s = args.worker_timeout_s
    if args.hidden:
        config.ppo.policy_hidden = config.ppo.value_hidden = args.hidden
    if args.torch_threads is not None:
        config.torch_threads = args.torch_threads
    if args.epochs is not None:
        config.ppo.update_epochs = args.epochs
    if args.policy_lr is not None:
        config.ppo.policy_lr = args.policy_lr
    if args.checkpoint_every:
        config.checkpoint_every = args.checkpoint_every
    env = config.env
    if args.physics_hz:
        env = dataclasses.replace(env, physics=PhysicsConfig(physics_hz=args.physics_hz))
    if args.no_early_termination:
        env = dataclasses.replace(env, early_termination=False)
    if args.ground_contact is not None:
        env = dataclasses.replace(env, ground_contact_links=args.ground_contact)
    if args.reward == "sfv_paper":
        from actors.reward import RewardConfig

        env = dataclasses.replace(env, reward=RewardConfig.sfv_paper())
    if args.action is not None:
        env = dataclasses.replace(env, action_parameterisation=args.action)
    if args.residual_scale is not None:
        if args.residual_scale < 0:
            raise SfvError(f"--residual-scale must be >= 0 (0: absolute targets), got {args.residual_scale}")
        env = dataclasses.replace(env, residual_action_scale=args.residual_scale or None)
    if env.action_parameterisation != "exp_map" and env.residual_action_scale is not None:
        raise SfvError("--action axis_angle needs --residual-scale 0: residual targets are exp-map offsets")
    if args.reference_obs is not None:
        env = dataclasses.replace(env, reference_obs_steps=args.reference_obs)
    if args.state_space is not None:
        env = dataclasses.replace(env, state_space=args.state_space)
    if args.asi_std_scale is not None:
        config.asi_initial_std_scale = args.asi_std_scale
    if args.curriculum_start_s is not None:
        config.curriculum_start_s = args.curriculum_start_s
    if args.curriculum_samples is not None:
        config.curriculum_samples = args.curriculum_samples
    if args.no_root_sync:
        env = dataclasses.replace(env, sync_root_per_cycle=False)
    if args.eval_every is not None:
        config.eval_every = args.eval_every
    if args.eval_episodes is not None:
        config.eval_episodes = args.eval_episodes
    config.env = env
    return config


def _positive(kind):
    """argparse type: a number of `kind` greater than zero (argparse names the flag on error)."""
    import argparse

    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            value = None
        if value is None or not value > 0:
            raise argparse.ArgumentTypeError(f"expected a positive {kind.__name__}, got {text!r}")
        return value

    parse.__name__ = kind.__name__
    return parse


def _steps(text: str) -> tuple[int, ...]:
    import argparse

    if text.strip().lower() == "none":
        return ()
    try:
        steps = tuple(int(part) for part in text.split(","))
    except ValueError:
        steps = ()
    if not steps or min(steps) < 1:
        raise argparse.ArgumentTypeError(f"expected positive step counts separated by commas, or 'none', got {text!r}")
    return steps


def _link_names(text: str) -> tuple[str, ...]:
    import argparse

    from actors.skeleton import LINK_NAMES

    if text.strip().lower() == "none":
        return ()
    names = tuple(part.strip() for part in text.split(",") if part.strip())
    unknown = [n for n in names if n not in LINK_NAMES]
    if not names or unknown:
        raise argparse.ArgumentTypeError(f"expected link names separated by commas (of {', '.join(LINK_NAMES)}), got {text!r}")
    return names


def _layer_sizes(text: str) -> tuple[int, ...]:
    import argparse

    try:
        sizes = tuple(int(part) for part in text.split(","))
    except ValueError:
        sizes = ()
    if not sizes or min(sizes) <= 0:
        raise argparse.ArgumentTypeError(f"expected positive integers separated by commas, got {text!r}")
    return sizes


def run(args) -> int:
    from services.training.driver import Trainer

    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    config = build_config(args)
    record = Trainer(config, resume=args.resume, progress=not args.quiet).run()
    summary = {k: record.get(k) for k in ("iteration", "samples", "normalized_return", "episode_length", "asi_version", "overall_samples_per_s")}
    print(json.dumps({"run": str(config.out), **summary}))
    return 0
