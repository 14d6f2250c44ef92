"""A training (Ray runner, embedded gRPC ASI server) whose local raylet is killed in its second
iteration; run as a child process by test_local_ray_private.py, so that a crash of this process
fails that test instead of ending the test session. Argument: a scratch directory."""
from __future__ import annotations

import os
import signal
import sys
from pathlib import Path

from actors.rollout.worker import RolloutWorker
from services.training.driver import Trainer
from services.training.run_dir import read_metrics
from tests.integration.test_train_integration import small_config


class KillsItsRayletWorker(RolloutWorker):
    """Worker 0 kills its raylet (its parent process) and itself in iteration 2, once."""

    def sample(self, weights, policy_version, steps, horizon_s=None):
        marker = Path(os.environ["SFV_TEST_MARKER"])
        if self.worker_index == 0 and policy_version == 1 and not marker.exists():
            marker.write_text(str(os.getppid()))
            os.kill(os.getppid(), signal.SIGKILL)
            os._exit(1)
        return super().sample(weights, policy_version, steps, horizon_s)


class Scenario(Trainer):
    worker_class = KillsItsRayletWorker


def main(scratch: Path) -> None:
    os.environ["SFV_TEST_MARKER"] = str(scratch / "killed")
    out = scratch / "run"
    Scenario(small_config(out, init="asi", samples=4 * 256), progress=False).run()
    rows = read_metrics(out)
    print("samples", [r["samples"] for r in rows], "ray_restarts", rows[-1]["ray_restarts"], "killed", (scratch / "killed").exists())


if __name__ == "__main__":
    main(Path(sys.argv[1]))
