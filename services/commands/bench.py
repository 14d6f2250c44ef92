"""`sfv bench --suite env|worker|learner|system|peer|pose|all [--quick] --out FILE.json`, and
`sfv bench --suite learning --out-dir DIR [...]` (services/bench/learning_suite.py: training runs, hours)."""
from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from learner.errors import SfvError


HELP = "throughput benchmarks: physics bound, env, worker, learner, training, peer, pose"  # the one line `sfv --help` lists (without importing the command)


def register(subparsers: argparse._SubParsersAction) -> None:
    from services.bench.config import SUITES, BenchConfig
    from services.bench.learning_suite import add_arguments as add_learning_arguments
    from services.bench.videos_suite import add_arguments as add_videos_arguments

    defaults = BenchConfig()
    p = subparsers.add_parser("bench", help=HELP)
    p.add_argument("--suite", default="all", help=f"{', '.join(SUITES)} or all; several comma-separated (default all); "
                                                  "or learning on its own (training runs: see the learning flags)")
    p.add_argument("--out", type=Path, default=None, help="JSON report to write (atomically); required except for --suite learning")
    p.add_argument("--quick", action="store_true", help="3 repetitions of 0.5 s, 2-iteration training runs (smoke runs, CI)")
    p.add_argument("--repeats", type=int, default=None, help=f"measured repetitions per variant (default {defaults.repeats}, quick 3)")
    p.add_argument("--seconds", type=float, default=None, help=f"length of one timed stepping measurement (default {defaults.seconds}, quick 0.5)")
    p.add_argument("--physics-hz", type=float, default=defaults.physics_hz, help="physics rate of the env/worker/system suites")
    p.add_argument("--envs-per-worker", type=int, default=defaults.envs_per_worker, help="M, envs of the worker in the env and system suites")
    p.add_argument("--system-iterations", type=int, default=None, help=f"PPO iterations per training run (default {defaults.system_iterations}, quick 2)")
    p.add_argument("--system-runners", default=None, metavar="R[,R]",
                   help=f"rollout runners of the system suite's training runs (default {','.join(defaults.system_runners)})")
    p.add_argument("--peer-python", default=None, help="interpreter that has pybullet_envs + gym 0.26.2 (default: this one)")
    p.add_argument("--pose-video", default=None, help="video of the pose suite (default ../shared pose2sim cam01.mp4)")
    p.add_argument("--pose-models", default=None, help="BlazePose model directory (default $SFV_POSE_MODELS, the cache, ../shared)")
    p.add_argument("--seed", type=int, default=0, help="seed of random actions, policy init and learner data")
    p.add_argument("--terrain", default=None, help="worker suite: also step envs-per-worker envs on this terrain (slopes, gaps, steps, rough, mixed) "
                                                   "at difficulty 1, with and without the heightmap (their ratios to the flat floor)")
    p.add_argument("--scaling-workers", default=None, help="scaling suite: comma-separated worker counts (default 1,2; the 16-core machine: 1,2,4,8,14)")
    p.add_argument("--scaling-runners", default=None, help="scaling suite: comma-separated runners (default processes,ray)")
    p.add_argument("--scaling-paced-workers", default=None, help="scaling suite: also emulated worker counts, e.g. 2,4,8,14 (processes that sleep "
                                                                "as long as a worker sampling --scaling-paced-rate would; the learner is real)")
    p.add_argument("--scaling-paced-rate", type=float, default=None, help="samples/s of each emulated worker (default 2300: one core's worker)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    add_learning_arguments(p)
    add_videos_arguments(p)
    p.set_defaults(handler=run_bench)


def build_config(args):
    from services.bench.config import BenchConfig
    from services.bench.env_suite import env_config_for
    from services.bench.runner import parse_suites

    try:
        suites = parse_suites(args.suite)
    except ValueError as exc:
        raise SfvError(f"--suite {args.suite!r}: {exc}") from None
    overrides = {"suites": suites, "physics_hz": args.physics_hz, "envs_per_worker": args.envs_per_worker, "seed": args.seed,
                 "peer_python": args.peer_python, "pose_video": args.pose_video, "pose_models": args.pose_models, "terrain": args.terrain}
    for name in ("repeats", "seconds", "system_iterations"):
        if getattr(args, name) is not None:
            overrides[name] = getattr(args, name)
    if args.system_runners is not None:
        overrides["system_runners"] = _system_runners(args.system_runners)
    if args.scaling_runners is not None:
        overrides["scaling_runners"] = _system_runners(args.scaling_runners, flag="--scaling-runners")
    if args.scaling_workers is not None:
        overrides["scaling_workers"] = _worker_counts(args.scaling_workers)
    if args.scaling_paced_workers is not None:
        overrides["scaling_paced_workers"] = _worker_counts(args.scaling_paced_workers, flag="--scaling-paced-workers")
    if args.scaling_paced_rate is not None:
        if not args.scaling_paced_rate > 0:
            raise SfvError(f"--scaling-paced-rate must be positive samples/s, got {args.scaling_paced_rate:g}")
        overrides["scaling_paced_rate"] = args.scaling_paced_rate
    config = BenchConfig.quick_defaults(**overrides) if args.quick else BenchConfig(**overrides)
    for name in ("repeats", "seconds", "system_iterations", "envs_per_worker", "physics_hz"):
        if not getattr(config, name) > 0:
            raise SfvError(f"--{name.replace('_', '-')} must be positive, got {getattr(config, name)}")
    try:
        env_config_for(config.physics_hz)
    except ValueError as exc:
        raise SfvError(f"--physics-hz: {exc}") from None
    return config


def _system_runners(text: str, flag: str = "--system-runners") -> tuple[str, ...]:
    from services.training.config import RUNNER_NAMES

    runners = tuple(r.strip() for r in text.split(",") if r.strip())
    bad = [r for r in runners if r not in RUNNER_NAMES]
    if bad or not runners:
        raise SfvError(f"{flag} {text!r}: choose from {', '.join(RUNNER_NAMES)}, comma-separated")
    return runners


def _worker_counts(text: str, flag: str = "--scaling-workers") -> tuple[int, ...]:
    try:
        counts = tuple(int(w) for w in text.split(",") if w.strip())
    except ValueError:
        counts = ()
    if not counts or min(counts) < 1:
        raise SfvError(f"{flag} {text!r}: comma-separated worker counts >= 1, e.g. 1,2,4")
    return counts


def run_bench(args) -> int:
    from services.bench.learning_suite import LEARNING_FLAGS, run_learning_command
    from services.bench.report import markdown_table, write_json_atomic
    from services.bench.runner import run_benchmarks

    names = {s.strip() for s in args.suite.split(",") if s.strip()}
    if "learning" in names:
        if names != {"learning"}:
            raise SfvError(f"--suite {args.suite!r}: the learning suite runs on its own (it trains for hours and writes OUT_DIR/learning.json)")
        return run_learning_command(args)
    if "videos" in names:
        from services.bench.videos_suite import run_videos_command

        if names != {"videos"}:
            raise SfvError(f"--suite {args.suite!r}: the videos suite runs on its own (a pipeline run per video)")
        return run_videos_command(args)
    given = [name for name in LEARNING_FLAGS if getattr(args, name, None) is not None]
    if given:
        raise SfvError(f"--{given[0].replace('_', '-')} belongs to --suite learning, not --suite {args.suite}")
    config = build_config(args)
    if args.out is None:
        raise SfvError(f"--out is required for --suite {args.suite} (the JSON report to write)")
    out = args.out
    if out.suffix != ".json":
        raise SfvError(f"{out}: the report must be a .json file")
    if not out.parent.is_dir():
        raise SfvError(f"{out}: directory {out.parent} does not exist")
    log = (lambda message: None) if args.quiet else (lambda message: print(message, file=sys.stderr, flush=True))
    report = run_benchmarks(config, log, command=command_line(args))
    write_json_atomic(out, report)
    if "scaling" in report["suites"] and not report["suites"]["scaling"].get("skipped"):
        from services.bench.scaling_suite import plot_scaling

        print(f"plot: {plot_scaling(report, out.with_suffix('.png'))}")
    print(markdown_table(report))
    print(f"\nwritten to {out}")
    return 0


def command_line(args) -> str:
    """The `sfv bench` command that reproduces this run (every option that differs from its default)."""
    from services.bench.config import BenchConfig

    defaults = BenchConfig()
    parts = ["sfv", "bench", "--suite", args.suite]
    if args.quick:
        parts.append("--quick")
    for name in ("repeats", "seconds", "physics_hz", "envs_per_worker", "system_iterations", "system_runners", "peer_python",
                 "pose_video", "pose_models", "seed", "scaling_workers", "scaling_runners", "scaling_paced_workers", "scaling_paced_rate"):
        value = getattr(args, name)
        default = getattr(defaults, name) if name in ("physics_hz", "envs_per_worker", "seed") else None
        if value is not None and value != default:
            parts += [f"--{name.replace('_', '-')}", f"{value:g}" if isinstance(value, float) else str(value)]
    parts += ["--out", str(args.out)]
    return " ".join(shlex.quote(p) for p in parts)
