"""A stop signal ends training at an iteration's end with a checkpoint (`services/training/stop_signals.py`):
SIGTERM from a scheduler, Ctrl-C from a terminal; a second signal acts at once."""
from __future__ import annotations

import os
import signal

import pytest

from learner.checkpoint import load_checkpoint
from services.training.run_dir import read_metrics
from services.training.stop_signals import STOP_SIGNALS, StopSignals
from tests.integration.test_faults_support import TrainProcess


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


def test_sigterm_ends_a_training_with_a_checkpoint_at_its_last_row_and_resume_goes_on(tmp_path):
    pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")
    run = tmp_path / "run"
    args = ("--motion", "deepmimic:walk", "--runner", "in_process", "--workers", "1", "--envs-per-worker", "2",
            "--batch-size", "64", "--eval-every", "0", "--quiet", "--checkpoint-every", "1000", "--plot-every", "0")
    with TrainProcess(run, *args, "--samples", "100000000") as training:
        training.wait_rows(lambda rows: len(rows) >= 2, timeout=300, what="two metrics rows (training under way)")
        training.send(signal.SIGTERM)
        assert training.wait(timeout=300) == 128 + signal.SIGTERM, training.output()
        message = training.stderr().strip().splitlines()[-1]
    assert message.startswith(f"sfv: {run}: stopped by SIGTERM at ") and "--resume" in message
    checkpoints = sorted(run.glob("checkpoint_*.pt"))
    assert len(checkpoints) == 1  # written by the stop (checkpoint_every is 1000)
    saved = load_checkpoint(checkpoints[0])
    rows = read_metrics(run)
    assert rows[-1]["iteration"] == saved["iteration"] and rows[-1]["samples"] == saved["samples"]  # no row past it
    with TrainProcess(run, *args, "--resume", "--samples", str(saved["samples"] + 64)) as resumed:
        assert resumed.wait(timeout=300) == 0, resumed.output()
    assert [row["iteration"] for row in read_metrics(run)][-2:] == [saved["iteration"], saved["iteration"] + 1]
