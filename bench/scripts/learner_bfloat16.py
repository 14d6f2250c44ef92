"""The learner/driver ceiling with the value network in bfloat16 against float32 (issue 45).

    python bench/scripts/learner_bfloat16.py --out bench/results/learner_bfloat16.json [--repeats 3]

The ceiling is the scaling suite's (`services/bench/scaling_suite.py`): two replaying workers
(`services/bench/recorded_worker.py`) feed the real training loop full PPO updates (no early
stop), the learner on `--threads` torch threads; its samples/s is what the learner and driver can
consume whatever the cores. Each repetition runs both settings, in rotating order, on the
asynchronous loop (lag 1) and the synchronous one. Also timed: one full update of 4,096 samples
alone (`PPOLearner.update`, the paper's 1024-512 networks). The JSON is written atomically.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # run from a checkout without installing

from services.bench.config import BenchConfig  # noqa: E402
from services.bench.measure import Summary, interleaved  # noqa: E402
from services.bench.report import write_json_atomic  # noqa: E402
from services.bench.runner import machine  # noqa: E402
from services.bench.scaling_suite import _train  # noqa: E402

LOOPS = {"async": 1, "sync": 0}


def update_seconds(value_bfloat16: bool, threads: int, samples: int = 4096) -> float:
    """Seconds of one full PPO update (no early stop) on the learner suite's random batch."""
    import numpy as np
    import torch

    from actors.character.features import OBS_DIM
    from learner.config import PPOConfig
    from learner.ppo import PPOLearner
    from services.bench.learner_suite import ACTION_DIM, random_batch

    torch.set_num_threads(threads)
    batch = random_batch(np.random.default_rng(0), samples)
    learner = PPOLearner(OBS_DIM, ACTION_DIM, PPOConfig(value_bfloat16=value_bfloat16, target_kl=None))
    learner.update(batch)  # warm-up
    start = time.perf_counter()
    for _ in range(3):
        learner.update(batch)
    return (time.perf_counter() - start) / 3


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", required=True, help="the JSON to write")
    p.add_argument("--repeats", type=int, default=3, help="repetitions of every setting")
    p.add_argument("--threads", type=int, default=2, help="torch threads of the learner")
    p.add_argument("--iterations", type=int, default=6, help="PPO iterations per ceiling run (the first is start-up)")
    args = p.parse_args(argv)
    config = BenchConfig(scaling_learner_threads=args.threads, scaling_iterations=args.iterations)
    with tempfile.TemporaryDirectory(prefix="sfv-bench-bf16-") as tmp:
        runs = iter(range(10**9))

        def ceiling(loop: str, bf16: bool):
            name = f"ceiling_{loop}_{'bf16' if bf16 else 'fp32'}"
            return lambda: {f"{name}_{k}": v for k, v in
                            _train(config, Path(tmp) / f"run{next(runs)}", "processes", 2, LOOPS[loop], "replay", bf16).items()}

        variants = {f"{loop}_{bf16}": ceiling(loop, bf16) for loop in LOOPS for bf16 in (False, True)}
        variants.update({f"update_{'bf16' if bf16 else 'fp32'}_s": (lambda bf16=bf16: update_seconds(bf16, args.threads))
                         for bf16 in (False, True)})
        values = interleaved(variants, args.repeats, warmup=0,
                             on_result=lambda r, n, v: print(f"rep {r + 1}: {n} = {v}", flush=True))
    record = {"bench": "learner_bfloat16", "machine": machine(), "threads": args.threads, "repeats": args.repeats,
              "what": "learner/driver ceiling (2 replaying workers, full updates) and one 4,096-sample update, value network "
                      "in bfloat16 (--ppo.value-bfloat16) against float32",
              "metrics": {name: Summary(tuple(v), "s" if name.endswith("_s") else "").to_dict() for name, v in values.items()}}
    write_json_atomic(Path(args.out), record)
    for name, summary in record["metrics"].items():
        print(f"{name}: median {summary['median']:,.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
