"""Local Rays that cannot kill each other: no fixed ports, workers at the driver's priority, and a
local Ray that dies under a run is started again while the run goes on."""
from __future__ import annotations

import logging
import os
import signal
import socket
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from services.ray_session import local_ray_alive, start_local_ray
from services.training.runners import RayRunner, WorkerFaults

pytestmark = pytest.mark.integration
RAY_AGENT_DEFAULT_PORT = 52365  # the dashboard agent's fixed port in Ray's own defaults


def _hold_port(port: int) -> socket.socket | None:
    """A listening socket on `port`, as another run's Ray agent holds it; None if it is taken already
    (then another Ray holds it, which is the same situation)."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        sock.bind(("0.0.0.0", port))
    except OSError:
        sock.close()
        return None
    sock.listen(1)
    return sock


def test_a_second_local_ray_takes_no_fixed_port_and_runs_workers_at_driver_priority():
    import ray

    held = _hold_port(RAY_AGENT_DEFAULT_PORT)
    try:
        start_local_ray(num_cpus=1)
        from ray._private.worker import global_worker

        assert global_worker.node.dashboard_agent_listen_port != RAY_AGENT_DEFAULT_PORT

        @ray.remote
        def niceness() -> int:
            return os.nice(0)

        assert ray.get(niceness.remote(), timeout=120) <= os.nice(0)  # Ray's default would be 15
        assert local_ray_alive()
    finally:
        ray.shutdown()
        if held is not None:
            held.close()


class KillsItsRayletWorker:
    """Worker 0 kills its raylet (its parent process) and itself on its first sample(), as the
    whole local Ray goes when the out-of-memory killer takes the raylet; a file remembers that
    it did, so the fresh Ray's worker answers."""

    def __init__(self, spec, index: int):
        self.marker, self.index = Path(spec["marker"]), index

    def pid(self) -> int:
        return os.getpid()

    def sample(self, weights, version, steps, **options):
        if self.index == 0 and not self.marker.exists():
            self.marker.write_text(str(os.getppid()))
            os.kill(os.getppid(), signal.SIGKILL)
            os._exit(1)  # a result sent now would reach the driver directly, past the dead raylet
        return {"worker_index": np.array(self.index), "worker_pid": np.array(os.getpid()),
                "policy_version": np.array(version)}


def test_a_local_ray_that_dies_is_started_again_and_the_iteration_collected_again(tmp_path, caplog):
    import ray

    config = SimpleNamespace(ray_address=None, workers=2, worker_timeout_s=60.0)
    faults = WorkerFaults()
    runner = RayRunner(config, KillsItsRayletWorker, faults)
    try:
        runner.start({"marker": str(tmp_path / "killed")})
        with caplog.at_level(logging.WARNING, logger="sfv.train"):
            results = runner.collect({}, 0, 1, {})
        assert (tmp_path / "killed").exists()  # the raylet really was killed
        assert sorted(int(r["worker_index"]) for r in results) == [0, 1]
        assert faults.ray_restarts == 1
        assert any("local Ray died" in r.getMessage() and "collected again" in r.getMessage() for r in caplog.records)
        assert len(runner.collect({}, 1, 1, {})) == 2 and faults.ray_restarts == 1  # and it goes on
    finally:
        ray.shutdown()
