"""The learning benchmark: skills x initial-state strategies x seeds, one training run each.

    python bench/learning.py --out-dir bench/results/learning [--skills walk,run] [--inits asi,rsi]
                             [--seeds 0,1] [--samples 2M] [--workers 2] [--envs-per-worker 32] [--serial]

The same code as `sfv bench --suite learning` (services/bench/learning_suite.py), with the
same flags; see that module for what it trains, measures and writes (OUT_DIR/learning.json,
OUT_DIR/learning.png, OUT_DIR/runs/), and for how a rerun resumes.
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout without installing

from services.cli import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main(["bench", *sys.argv[1:], "--suite", "learning"]))  # last: always the learning suite
