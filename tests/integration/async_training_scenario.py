"""An asynchronous training (--max-policy-lag 1) of 5 iterations, then resumed to 7; run as a
child process by test_async_training.py: a fresh interpreter forks Ray's processes with no
threads left over from earlier tests (a forked child of the full test session crashed in
threading._after_fork and the local Ray did not start). Arguments: runner, run directory."""
from __future__ import annotations

import sys
from pathlib import Path

from services.training.driver import Trainer
from tests.integration.test_train_integration import small_config


def main(runner: str, out: Path) -> None:
    import ray

    try:
        Trainer(small_config(out, init="rsi", runner=runner, max_policy_lag=1, samples=5 * 256), progress=False).run()
        Trainer(small_config(out, init="rsi", runner=runner, max_policy_lag=1, samples=7 * 256), resume=True,
                progress=False).run()
    finally:
        ray.shutdown()


if __name__ == "__main__":
    main(sys.argv[1], Path(sys.argv[2]))
