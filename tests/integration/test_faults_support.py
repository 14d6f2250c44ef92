"""Shared helpers of the fault, cluster and security tests (this module holds no tests).

`TrainProcess` runs `sfv train` as a real subprocess with a tiny network so a run takes
seconds; `wait_for` polls a condition with a deadline (the tests never sleep as logic).
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from services.training.run_dir import read_metrics

REPO = Path(__file__).resolve().parents[2]
# Small and fast: 256-sample iterations, 64-32 MLPs, an ASI step every 8 episodes, a checkpoint per iteration.
TINY_RUN = ("--batch-size", "256", "--hidden", "64,32", "--asi-episodes-per-update", "8", "--checkpoint-every", "1", "--quiet")


def wait_for(condition, timeout: float, what: str, interval: float = 0.05, process: "TrainProcess | None" = None):
    """Poll `condition()` until it returns something truthy (returned); AssertionError after `timeout` s.

    With `process`, also fail as soon as that process exits (its output goes into the message).
    """
    deadline = time.monotonic() + timeout
    while True:
        value = condition()
        if value:
            return value
        if process is not None and process.poll() is not None:
            raise AssertionError(f"{what}: sfv train exited {process.poll()} first:\n{process.output()}")
        if time.monotonic() > deadline:
            detail = f"\n{process.output()}" if process is not None else ""
            raise AssertionError(f"{what}: not within {timeout:g} s{detail}")
        time.sleep(interval)


def clean_env(**extra: str) -> dict:
    """The test process's environment without an ambient ASI token, plus `extra`."""
    env = {k: v for k, v in os.environ.items() if k != "SFV_ASI_TOKEN"}
    env.setdefault("PYTHONPATH", str(REPO))
    env.update(extra)
    return env


class TrainProcess:
    """`python -m services.cli train --out OUT ARGS...`; stdout and stderr go to files beside the run.

    It runs in a session of its own; closing kills, by id, every process still in that session
    (the local Ray it may have started), so a failed test leaves nothing running.
    """

    def __init__(self, out: Path, *args: str, env: dict | None = None):
        self.out = Path(out)
        self.stdout_path = self.out.parent / f"{self.out.name}.stdout"
        self.stderr_path = self.out.parent / f"{self.out.name}.stderr"
        self._stdout, self._stderr = open(self.stdout_path, "wb"), open(self.stderr_path, "wb")
        self.command = [sys.executable, "-m", "services.cli", "train", "--out", str(self.out), *args]
        self.started = time.monotonic()
        self.process = subprocess.Popen(self.command, cwd=REPO, env=env if env is not None else clean_env(),
                                        stdout=self._stdout, stderr=self._stderr, start_new_session=True)
        self.pid = self.process.pid

    def poll(self) -> int | None:
        return self.process.poll()

    def rows(self) -> list[dict]:
        return read_metrics(self.out)

    def stdout(self) -> str:
        return self.stdout_path.read_text(errors="replace")

    def stderr(self) -> str:
        return self.stderr_path.read_text(errors="replace")

    def output(self) -> str:
        return f"$ {' '.join(self.command)}\n--- stdout\n{self.stdout()[-3000:]}\n--- stderr\n{self.stderr()[-6000:]}"

    def wait_rows(self, condition, timeout: float, what: str) -> list[dict]:
        """Poll metrics.jsonl until `condition(rows)` holds; returns the rows."""
        return wait_for(lambda: (lambda rows: rows if condition(rows) else None)(self.rows()), timeout, what, process=self)

    def wait(self, timeout: float) -> int:
        try:
            return self.process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.kill()
            raise AssertionError(f"sfv train still running after {timeout:g} s (killed):\n{self.output()}") from None

    def send(self, signum: int) -> None:
        if self.process.poll() is None:
            os.kill(self.pid, signum)

    def kill(self) -> None:
        """SIGKILL (resuming it first if it was stopped) and reap."""
        if self.process.poll() is None:
            os.kill(self.pid, signal.SIGCONT)
            self.process.kill()
        self.process.wait()

    def close(self) -> None:
        left = session_members(self.pid)
        self.kill()
        for pid in left + session_members(self.pid):
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        self._stdout.close()
        self._stderr.close()

    def __enter__(self) -> "TrainProcess":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _stat_fields(pid: int | str) -> list[str] | None:
    """Fields of /proc/PID/stat after the command name: [state, ppid, pgrp, session, ...]."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return None


def session_members(session: int) -> list[int]:
    """Live processes of session `session` other than its leader."""
    members = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit() and int(entry.name) != session:
            fields = _stat_fields(entry.name)
            if fields and int(fields[3]) == session and fields[0] != "Z":
                members.append(int(entry.name))
    return members


def descendants(pid: int) -> list[int]:
    """Every live process below `pid` (children, their children, ...), from /proc."""
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        fields = _stat_fields(entry.name) if entry.name.isdigit() else None
        if fields:
            children.setdefault(int(fields[1]), []).append(int(entry.name))
    found, stack = [], [pid]
    while stack:
        for child in children.get(stack.pop(), []):
            found.append(child)
            stack.append(child)
    return found


def cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace").strip()
    except OSError:
        return ""
