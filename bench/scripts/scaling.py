"""Training throughput from 1 to N rollout workers, without Ray (for machines without it).

    python bench/scripts/scaling.py --max-workers 16 --out scaling.json [--device cuda] [--quick]

Each worker is a `RolloutWorker` in its own process (multiprocessing, spawn), driven by the
real training loop (`services.training.driver.Trainer`: PPO learner, embedded ASI server, metrics,
checkpoints), with the processes runner (`services/training/runners/processes.py`): pipes
instead of Ray actors. Worker processes get one BLAS/OpenMP thread each, as Ray gives its
1-CPU actors.

Every repetition measures, in rotating order, one training run per worker count and the
raw physics bound on one core (MuJoCo alone, see services/bench/steppers.py); reported are
samples/s of each run (learning included) and its ratio to raw x workers. With
--parallel-raw the bound is also measured with N processes stepping at once (what the
machine's cores deliver together, memory and clock limits included). The JSON is rewritten
after every repetition, so a run cut short still leaves its measurements.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # run from a checkout without installing

from services.bench.env_suite import env_config_for  # noqa: E402
from services.bench.measure import Summary, rate_for, ratio  # noqa: E402
from services.bench.parallel_raw import parallel_raw_steps_per_s  # noqa: E402
from services.bench.report import markdown_table, write_json_atomic  # noqa: E402
from services.bench.result import SuiteResult  # noqa: E402
from services.bench.runner import machine  # noqa: E402
from services.bench.steppers import RawPhysics  # noqa: E402
from services.training.config import TrainConfig  # noqa: E402
from services.training.driver import Trainer  # noqa: E402


def train_samples_per_s(args, workers: int, out: Path) -> float:
    config = TrainConfig(motion=args.motion, out=str(out), workers=workers, envs_per_worker=args.envs_per_worker,
                         init="asi", seed=0, device=args.device, env=env_config_for(args.physics_hz), runner="processes")
    config.samples = args.iterations * config.ppo.batch_size
    with Trainer(config, progress=False) as trainer:
        return trainer.run()["overall_samples_per_s"]


# ----------------------------------------------------------------------------- main
def parse_args(argv=None):
    cpus = len(os.sched_getaffinity(0))
    p = argparse.ArgumentParser(description="training throughput vs worker count, without Ray")
    p.add_argument("--max-workers", type=int, default=cpus, help=f"largest worker count (default: usable cores, {cpus})")
    p.add_argument("--workers", default=None, help="comma-separated worker counts (default 1, 2, 4, ... up to --max-workers)")
    p.add_argument("--iterations", type=int, default=5, help="PPO iterations (4096 samples each) per training run")
    p.add_argument("--repeats", type=int, default=3, help="repetitions of every worker count")
    p.add_argument("--seconds", type=float, default=2.0, help="length of one raw-bound measurement")
    p.add_argument("--envs-per-worker", type=int, default=32, help="envs per worker")
    p.add_argument("--physics-hz", type=float, default=300.0, help="physics rate")
    p.add_argument("--motion", default="deepmimic:walk", help="reference motion")
    p.add_argument("--device", default="cpu", help="torch device of the learner (cpu, cuda)")
    p.add_argument("--parallel-raw", action="store_true", help="also measure the raw bound with N processes at once")
    p.add_argument("--quick", action="store_true", help="1 repetition, 2 iterations, 0.5 s raw measurements")
    p.add_argument("--out", type=Path, required=True, help="JSON report (rewritten after every repetition)")
    args = p.parse_args(argv)
    if args.quick:
        args.repeats, args.iterations, args.seconds = 1, 2, 0.5
    if args.workers:
        args.counts = sorted({int(w) for w in args.workers.split(",")})
    else:
        args.counts = sorted({min(2 ** k, args.max_workers) for k in range(args.max_workers.bit_length() + 1)})
    if min(args.counts) < 1 or args.repeats < 1 or args.iterations < 1:
        p.error("worker counts, --repeats and --iterations must be positive")
    if args.out.suffix != ".json" or not args.out.parent.is_dir():
        p.error(f"--out {args.out}: must be a .json file in an existing directory")
    return args


def build_result(args, runs: dict[str, list[float]], complete: int) -> SuiteResult:
    metrics = {"raw_steps_per_s": Summary(tuple(runs["raw_steps_per_s"][:complete]), "control steps/s (1 core)")}
    for n in args.counts:
        metrics[f"train_{n}w_samples_per_s"] = Summary(tuple(runs[f"train_{n}w_samples_per_s"][:complete]), "samples/s incl. learning")
        if args.parallel_raw:
            metrics[f"raw_{n}p_steps_per_s"] = Summary(tuple(runs[f"raw_{n}p_steps_per_s"][:complete]), f"control steps/s, {n} processes")
    settings = {key: getattr(args, key) for key in ("counts", "iterations", "repeats", "seconds", "envs_per_worker",
                                                     "physics_hz", "motion", "device", "parallel_raw")}
    result = SuiteResult("scaling", metrics, settings={**settings, "transport": "multiprocessing pipes (spawn), no Ray",
                                                       "completed_repetitions": complete})
    for n in args.counts:
        result.ratios[f"train_{n}w_over_raw"] = ratio(metrics, f"train_{n}w_samples_per_s", "raw_steps_per_s", scale=n)
        if args.parallel_raw:
            result.ratios[f"train_{n}w_over_raw_{n}p"] = ratio(metrics, f"train_{n}w_samples_per_s", f"raw_{n}p_steps_per_s")
    return result


def main(argv=None) -> int:
    args = parse_args(argv)
    raw = RawPhysics(env_config_for(args.physics_hz))
    variants = {"raw_steps_per_s": lambda: rate_for(args.seconds, raw.chunk).wall}
    with tempfile.TemporaryDirectory(prefix="sfv-scaling-") as tmp:
        counter = iter(range(10**6))
        for n in args.counts:
            variants[f"train_{n}w_samples_per_s"] = lambda n=n: train_samples_per_s(args, n, Path(tmp) / f"run{next(counter)}")
            if args.parallel_raw:
                variants[f"raw_{n}p_steps_per_s"] = lambda n=n: parallel_raw_steps_per_s(args.physics_hz, args.seconds, n)
        print(f"warm-up: 1 iteration with {max(args.counts)} workers", file=sys.stderr, flush=True)
        saved_iterations, args.iterations = args.iterations, 1
        train_samples_per_s(args, max(args.counts), Path(tmp) / "warmup")
        args.iterations = saved_iterations
        names = list(variants)
        runs: dict[str, list[float]] = {name: [] for name in names}
        report = {"command": "python bench/scripts/scaling.py " + " ".join(sys.argv[1:] if argv is None else argv),
                  "machine": machine(), "load_average_start": list(os.getloadavg()), "suites": {}}
        started = time.perf_counter()
        for r in range(args.repeats):
            k = r % len(names)
            for name in names[k:] + names[:k]:
                runs[name].append(variants[name]())
                print(f"rep {r + 1}: {name} = {runs[name][-1]:,.0f}", file=sys.stderr, flush=True)
            result = build_result(args, runs, r + 1)
            result.seconds = time.perf_counter() - started
            report["suites"]["scaling"] = result.to_dict()
            report["load_average_end"] = list(os.getloadavg())
            write_json_atomic(args.out, report)
    print(markdown_table(report))
    print(f"\nwritten to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
