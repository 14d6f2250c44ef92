"""Shared builders for the ASI tests: a small reference clip and valid requests to mutate."""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from proto import asi_pb2

K, D, FRAMES = 3, 5, 16


def reference_clip(seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(FRAMES, D) float32 states and their phases linspace(0, 1, FRAMES); frame f holds f in column 0."""
    rng = np.random.default_rng(seed)
    states = rng.normal(size=(FRAMES, D)).astype(np.float32)
    states[:, 0] = np.arange(FRAMES)
    return states, np.linspace(0.0, 1.0, FRAMES)


def create_request(job_id: str = "job", **overrides) -> asi_pb2.CreateJobRequest:
    states, phases = reference_clip()
    fields = dict(job_id=job_id, state_dim=D, num_components=K, reference_states_f32=states.tobytes(),
                  reference_phases=phases)
    fields.update(overrides)
    return asi_pb2.CreateJobRequest(**fields)


def report_request(job_id: str = "job", n: int = 4, seed: int = 0, **overrides) -> asi_pb2.ReportRequest:
    rng = np.random.default_rng(seed)
    fields = dict(job_id=job_id, initial_states_f32=rng.normal(size=(n, D)).astype("<f4").tobytes(),
                  components=rng.integers(K, size=n), returns=rng.normal(size=n))
    fields.update(overrides)
    return asi_pb2.ReportRequest(**fields)


REPO_ROOT = Path(__file__).resolve().parents[1]


class ServerProcess:
    """`sfv asi-server` in a subprocess; its log goes to a file so a full pipe never blocks it."""

    def __init__(self, log_path: Path, *args: str, env: dict | None = None):
        self.log_path = log_path
        environment = {**os.environ, "PYTHONPATH": str(REPO_ROOT), **(env or {})}
        self._log = open(log_path, "wb")
        # The command module directly: the same handler as `sfv asi-server` without importing other sub-commands.
        self.process = subprocess.Popen([sys.executable, "-m", "services.commands.asi_server", *args], cwd=REPO_ROOT,
                                        env=environment, stdout=self._log, stderr=subprocess.STDOUT)
        self.address = None

    def log_text(self) -> str:
        return self.log_path.read_text(errors="replace")

    def wait_listening(self, timeout: float = 30.0) -> str:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            match = re.search(r"listening on (\S+)", self.log_text())
            if match:
                self.address = match.group(1)
                return self.address
            if self.process.poll() is not None:
                raise AssertionError(f"asi-server exited {self.process.returncode}: {self.log_text()}")
            time.sleep(0.02)
        raise AssertionError(f"asi-server did not start in {timeout} s: {self.log_text()}")

    def wait_exit(self, timeout: float = 20.0) -> int:
        try:
            return self.process.wait(timeout=timeout)
        finally:
            self._log.close()

    def stop(self) -> int:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
        try:
            return self.wait_exit()
        except subprocess.TimeoutExpired:
            self.process.kill()
            return self.wait_exit()

    def rss_bytes(self) -> int:
        for line in Path(f"/proc/{self.process.pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) * 1024
        raise AssertionError("no VmRSS in /proc status")
