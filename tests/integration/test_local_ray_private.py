"""Local Rays that cannot kill each other: no fixed ports, workers at the driver's priority, and a
local Ray that dies under a run is started again while the run goes on."""
from __future__ import annotations

import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from services.ray_session import local_ray_alive, start_local_ray

pytestmark = pytest.mark.integration
RAY_AGENT_DEFAULT_PORT = 52365
REPO = Path(__file__).resolve().parents[2]  # the dashboard agent's fixed port in Ray's own defaults


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


def test_a_training_whose_local_ray_dies_goes_on_from_the_iteration_it_was_in(tmp_path):
    """The whole path: a Ray-runner training with its embedded gRPC ASI server; the raylet is
    killed in iteration 2; the run starts a fresh local Ray and reaches its budget. In a child
    process: a crash there (Ray and gRPC in one process) fails this test, not the session."""
    # One retry, in a fresh directory. Measured 2026-12-06: 1 of 3 full-suite runs ended the
    # scenario with exit 1 and no output at all (the driver gone while its raylet was being
    # killed, before any restart line), 0 of 5 runs alone; the cause is not found yet (issue 45's
    # note), so the second attempt tells that race from a restart path that does not work.
    failures = []
    for attempt in range(2):
        scratch = tmp_path / f"attempt{attempt}"
        scratch.mkdir()
        done = subprocess.run([sys.executable, "-m", "tests.integration.ray_death_scenario", str(scratch)],
                              capture_output=True, text=True, timeout=900, cwd=REPO)
        if done.returncode == 0:
            break
        log = scratch / "run" / "sfv.log"
        failures.append(f"exit {done.returncode}; stderr: {done.stderr[-1500:]!r}; "
                        f"sfv.log: {log.read_text()[-1500:] if log.is_file() else 'none'!r}")
    assert done.returncode == 0, "\n".join(failures)
    last = done.stdout.strip().splitlines()[-1]
    assert last == "samples [256, 512, 768, 1024] ray_restarts 1 killed True", last
    assert "the local Ray died" in done.stderr and "iteration 2 is collected again" in done.stderr
