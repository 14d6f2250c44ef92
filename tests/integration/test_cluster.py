"""`sfv train` as a Ray job on a real Ray cluster (head started with `ray start`, token auth on).

The head runs `ray start --head --block` in its own session and temp dir, on free ports, so
it never meets another Ray on the machine; it is stopped by signalling that process (not
`ray stop`, which would stop every Ray on the machine) and any process it left is killed by
id. The job is submitted with `ray job submit --working-dir <repo>` (excluding the venv, git,
tests and runs); Ray 2.60 requires the cluster token (RAY_AUTH_TOKEN) in the submitting
client's environment, and the dashboard refuses job requests without it.
"""
from __future__ import annotations

import json
import os
import secrets
import shutil
import signal
import subprocess
import sys
import tempfile
import urllib.error
import urllib.request
import uuid
from pathlib import Path

import pytest

from learner.checkpoint import latest_checkpoint, load_checkpoint
from services.training.run_dir import read_metrics
from tests.redis_fixture import free_port
from tests.integration.test_faults_support import REPO, TINY_RUN, clean_env, descendants, session_members, wait_for

pytestmark = pytest.mark.integration

RAY_CLI = Path(sys.executable).with_name("ray")
WORKING_DIR_EXCLUDES = ["/.venv", "/.git", "/runs", "/tests", "/bench", "__pycache__", "*.egg-info", "*.pt"]


class RayHead:
    def __init__(self, workdir: Path):
        self.workdir = workdir
        self.token = secrets.token_hex(32)
        self.dashboard_port = free_port()
        self.env = clean_env(RAY_AUTH_MODE="token", RAY_AUTH_TOKEN=self.token, RAY_USAGE_STATS_ENABLED="0",
                             PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}")
        ports = {name: free_port() for name in ("port", "dashboard-agent-listen-port", "dashboard-agent-grpc-port",
                                                 "runtime-env-agent-port", "metrics-export-port", "ray-client-server-port")}
        self.command = [str(RAY_CLI), "start", "--head", "--block", "--node-ip-address=127.0.0.1",
                        "--dashboard-host=127.0.0.1", f"--dashboard-port={self.dashboard_port}", "--include-dashboard=true",
                        "--num-cpus=2", "--object-store-memory=100000000", "--disable-usage-stats",
                        f"--temp-dir={workdir / 'ray'}", *(f"--{name}={port}" for name, port in ports.items())]
        self.log_path = workdir / "head.log"
        self._log = open(self.log_path, "wb")
        self.process = subprocess.Popen(self.command, env=self.env, stdout=self._log, stderr=subprocess.STDOUT,
                                        start_new_session=True)

    @property
    def address(self) -> str:
        return f"http://127.0.0.1:{self.dashboard_port}"

    def api(self, path: str, token: str | None = "own") -> tuple[int, dict | None]:
        """GET the Jobs REST API; token 'own' sends the cluster's token, None sends none."""
        request = urllib.request.Request(self.address + path)
        if token is not None:
            request.add_header("Authorization", f"Bearer {self.token if token == 'own' else token}")
        try:
            with urllib.request.urlopen(request, timeout=10) as reply:
                return reply.status, json.loads(reply.read() or b"null")
        except urllib.error.HTTPError as error:
            return error.code, None
        except (urllib.error.URLError, ConnectionError, TimeoutError):
            return 0, None

    def wait_ready(self, timeout: float = 180.0) -> None:
        def up():
            if self.process.poll() is not None:
                raise AssertionError(f"ray start exited {self.process.returncode}:\n{self.log_path.read_text()[-4000:]}")
            return self.api("/api/jobs/")[0] == 200

        wait_for(up, timeout, "Ray dashboard answering", interval=0.5)

    def ray(self, *args: str, timeout: float = 300) -> subprocess.CompletedProcess:
        return subprocess.run([str(RAY_CLI), *args], cwd=REPO, env=self.env, capture_output=True, text=True, timeout=timeout)

    def stop(self) -> list[int]:
        """SIGTERM the head (it stops the processes it started); SIGKILL, by id, whatever outlived it."""
        ours = set(descendants(self.process.pid)) | set(session_members(self.process.pid))
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=90)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self._log.close()
        survivors = [pid for pid in ours if Path(f"/proc/{pid}").exists()]
        for pid in survivors:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        return survivors


@pytest.fixture
def ray_head():
    if not RAY_CLI.exists():
        pytest.skip(f"{RAY_CLI} not installed")
    # A short temp dir: Ray's unix socket paths under it must stay below 108 bytes.
    workdir = Path(tempfile.mkdtemp(prefix="sfvray", dir="/tmp"))
    head = RayHead(workdir)
    try:
        head.wait_ready()
        yield head
    finally:
        head.stop()
        shutil.rmtree(workdir, ignore_errors=True)


@pytest.mark.slow
def test_training_job_on_a_token_auth_cluster(ray_head, tmp_path):
    # The dashboard refuses job requests without the cluster token (401) or with another one (403).
    assert ray_head.api("/api/jobs/", token=None)[0] == 401
    assert ray_head.api("/api/jobs/", token=secrets.token_hex(32))[0] == 403

    out = tmp_path / "run"
    job_id = f"sfv-test-{uuid.uuid4().hex[:8]}"
    entrypoint = [sys.executable, "-m", "services.cli", "train", "--ray-address", "auto", "--workers", "2",
                  "--envs-per-worker", "4", "--init", "asi", "--samples", "512", "--out", str(out), *TINY_RUN]
    submitted = ray_head.ray("job", "submit", "--address", ray_head.address, "--submission-id", job_id, "--no-wait",
                             "--working-dir", str(REPO), "--runtime-env-json", json.dumps({"excludes": WORKING_DIR_EXCLUDES}),
                             "--", *entrypoint)
    assert submitted.returncode == 0, submitted.stdout + submitted.stderr

    def finished():
        status, info = ray_head.api(f"/api/jobs/{job_id}")
        return info["status"] if status == 200 and info and info["status"] in ("SUCCEEDED", "FAILED", "STOPPED") else None

    final = wait_for(finished, 420, f"job {job_id} finishing", interval=1.0)
    logs = ray_head.ray("job", "logs", "--address", ray_head.address, job_id).stdout
    assert final == "SUCCEEDED", logs[-6000:]

    summary = json.loads(next(line for line in reversed(logs.splitlines()) if line.startswith('{"run"')))
    assert summary["samples"] == 512 and summary["run"] == str(out)
    rows = read_metrics(out)
    assert [r["samples"] for r in rows] == [256, 512]
    assert all(r["batch_policy_versions"] == [r["iteration"] - 1] and len(r["batch_worker_indices"]) == 2 for r in rows)
    assert rows[-1]["asi_version"] >= 1 and rows[-1]["worker_failures"] == 0
    checkpoint = load_checkpoint(latest_checkpoint(out))
    assert checkpoint["samples"] == 512 and checkpoint["config"]["ray_address"] == "auto"
    print(f"\ncluster job {job_id}: {final}, {len(rows)} iterations, asi version {rows[-1]['asi_version']}")
