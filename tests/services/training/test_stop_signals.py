"""A stop signal ends training at an iteration's end with a checkpoint (`services/training/stop_signals.py`):
SIGTERM from a scheduler, Ctrl-C from a terminal; a second signal acts at once."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from learner.checkpoint import load_checkpoint
from services.training.stop_signals import STOP_SIGNALS, StopSignals
from tests.conftest import REPO


def test_a_stop_signal_is_held_for_the_loop_and_the_handlers_come_back():
    before = {number: signal.getsignal(number) for number in STOP_SIGNALS}
    with StopSignals() as stop:
        assert stop.requested is None
        os.kill(os.getpid(), signal.SIGTERM)  # without the handler this would end pytest
        assert stop.requested == signal.SIGTERM and stop.name == "SIGTERM"
    assert {number: signal.getsignal(number) for number in STOP_SIGNALS} == before


def test_a_second_ctrl_c_interrupts_at_once():
    with pytest.raises(KeyboardInterrupt):
        with StopSignals() as stop:
            os.kill(os.getpid(), signal.SIGINT)
            assert stop.requested == signal.SIGINT
            os.kill(os.getpid(), signal.SIGINT)
            for _ in range(10_000):  # the handler runs between bytecodes: this loop is where it lands
                pass


def _rows(path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()] if path.exists() else []


def test_sigterm_ends_a_training_with_a_checkpoint_at_its_last_row_and_resume_goes_on(tmp_path):
    pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")
    run = tmp_path / "run"
    base = [sys.executable, "-m", "services.cli", "train", "--motion", "deepmimic:walk", "--runner", "in_process",
            "--workers", "1", "--envs-per-worker", "2", "--batch-size", "64", "--eval-every", "0", "--quiet",
            "--checkpoint-every", "1000", "--plot-every", "0", "--out", str(run)]
    process = subprocess.Popen([*base, "--samples", "100000000"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO)
    try:
        deadline = time.monotonic() + 300
        while len(_rows(run / "metrics.jsonl")) < 2:  # training is under way (a condition, not a fixed wait)
            assert process.poll() is None and time.monotonic() < deadline, process.stderr.read()[-2000:] if process.poll() is not None else "no rows in 300 s"
            time.sleep(0.1)
        process.send_signal(signal.SIGTERM)
        out, err = process.communicate(timeout=300)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 128 + signal.SIGTERM, err[-2000:]
    message = err.strip().splitlines()[-1]
    assert message.startswith(f"sfv: {run}: stopped by SIGTERM at ") and "--resume" in message
    checkpoints = sorted(run.glob("checkpoint_*.pt"))
    assert len(checkpoints) == 1  # written by the stop (checkpoint_every is 1000)
    saved = load_checkpoint(checkpoints[0])
    rows = _rows(run / "metrics.jsonl")
    assert rows[-1]["iteration"] == saved["iteration"] and rows[-1]["samples"] == saved["samples"]  # no row past it
    done = subprocess.run([*base, "--resume", "--samples", str(saved["samples"] + 64)], capture_output=True, text=True,
                          timeout=300, cwd=REPO)
    assert done.returncode == 0, done.stderr[-2000:]
    assert [row["iteration"] for row in _rows(run / "metrics.jsonl")][-2:] == [saved["iteration"], saved["iteration"] + 1]
