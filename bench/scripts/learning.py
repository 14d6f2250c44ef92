"""The learning benchmark: skills x initial-state strategies x seeds, one training run each.

    python bench/scripts/learning.py --out-dir bench/results/learning [--skills walk,run] [--inits asi,rsi]
                             [--seeds 0,1] [--samples 2M] [--workers 2] [--envs-per-worker 32] [--serial]

The same code and flags as `sfv bench --suite learning` (services/bench/learning_suite.py);
see that module for what it trains, measures and writes (OUT_DIR/learning.json,
OUT_DIR/learning.png, OUT_DIR/runs/), and for how a rerun resumes. It parses its flags itself
rather than through the `sfv` command line, which imports this package (no import circle).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # run from a checkout without installing


def main(argv: list[str] | None = None) -> int:
    from learner.errors import SfvError
    from services.bench.learning_suite import add_arguments, run_learning_command

    parser = argparse.ArgumentParser(prog="learning.py", description="the learning suite of `sfv bench`")
    add_arguments(parser)
    # The flags `sfv bench` shares between its suites that the learning suite reads.
    parser.add_argument("--envs-per-worker", type=int, default=None, help="envs per rollout worker")
    parser.add_argument("--physics-hz", type=float, default=None, help="physics rate of every run")
    parser.add_argument("--seed", type=int, default=0, help="base seed when --seeds is not given")
    parser.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    args = parser.parse_args(argv)
    try:
        return run_learning_command(args)
    except SfvError as exc:
        print(f"learning.py: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
