"""The training process SIGKILLed after a checkpoint: `--resume` carries on exactly from it.

A real `sfv train` subprocess (serial workers, embedded ASI server on a real Redis, a checkpoint
every 2 iterations) is killed right after an odd iteration, so metrics.jsonl holds a row the
checkpoint does not cover. A torn checkpoint newer than the last good one and the temp
file of an unfinished atomic write are then left in the run directory, as a crash during the
write could leave them; the resumed run must skip both (with a warning), load the last good
checkpoint bit for bit, and continue the sample count and the ASI job from it.
"""
from __future__ import annotations

import copy
import json
import logging
import signal

import pytest
import torch

from learner.checkpoint import checkpoint_path, latest_checkpoint, load_checkpoint
from services.training.config import TrainConfig
from services.training.driver import Trainer
from services.training.run_dir import CONFIG_FILE, read_metrics
from tests.integration.test_faults_support import TINY_RUN, TrainProcess

pytestmark = pytest.mark.integration

BATCH = 256


def assert_same(resumed, saved, where="learner"):
    """Bitwise equality of two state dicts (tensors, numbers, strings, nested containers)."""
    if isinstance(saved, torch.Tensor):
        assert isinstance(resumed, torch.Tensor) and resumed.dtype == saved.dtype and torch.equal(resumed, saved), where
    elif isinstance(saved, dict):
        assert set(resumed) == set(saved), f"{where}: keys {sorted(map(str, resumed))} != {sorted(map(str, saved))}"
        for key in saved:
            assert_same(resumed[key], saved[key], f"{where}[{key!r}]")
    elif isinstance(saved, (list, tuple)):
        assert len(resumed) == len(saved), where
        for index, (a, b) in enumerate(zip(resumed, saved)):
            assert_same(a, b, f"{where}[{index}]")
    else:
        assert resumed == saved, f"{where}: {resumed!r} != {saved!r}"


class ObservedTrainer(Trainer):
    """Records the learner's state right after the checkpoint is loaded, before any update."""

    def _restore(self, learner, checkpoint):
        asi_version = super()._restore(learner, checkpoint)
        self.state_after_load = copy.deepcopy(learner.state_dict())
        self.samples_after_load, self.iteration_after_load = self.samples, self.iteration
        return asi_version


def test_sigkilled_run_resumes_from_last_good_checkpoint(tmp_path, redis_url, caplog):
    out = tmp_path / "run"
    args = ("--serial", "--workers", "1", "--envs-per-worker", "4", "--init", "asi", "--redis-url", redis_url,
            "--samples", str(100 * BATCH), *TINY_RUN, "--checkpoint-every", "2")
    with TrainProcess(out, *args) as train:
        train.wait_rows(lambda rows: len(rows) >= 3 and len(rows) % 2 == 1, 180, "an odd iteration after a checkpoint")
        train.send(signal.SIGKILL)
        assert train.process.wait(timeout=30) == -signal.SIGKILL
    good = latest_checkpoint(out)
    saved = load_checkpoint(good)
    rows_at_kill = read_metrics(out)
    assert saved["samples"] == saved["iteration"] * BATCH < 100 * BATCH
    assert len(rows_at_kill) > saved["iteration"], "no iteration after the checkpoint to redo"

    # What a crash during the next checkpoint write could leave: a torn file under the final name
    # (only possible without atomic writes, e.g. a copy by hand) and an unfinished temp file.
    torn = checkpoint_path(out, saved["iteration"] + 2)
    assert not torn.exists()
    torn.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    leftover = out / f".{torn.name}.k1ll3d.tmp"
    leftover.write_bytes(b"half a checkpoint")

    config = TrainConfig.from_dict(json.loads((out / CONFIG_FILE).read_text()))
    config.samples = saved["samples"] + 2 * BATCH
    trainer = ObservedTrainer(config, resume=True, progress=False)
    with caplog.at_level(logging.WARNING, logger="sfv.train"):
        record = trainer.run()

    # The resumed learner is the checkpoint file's content, weights and optimiser state alike.
    assert_same(trainer.state_after_load, saved["learner"])
    assert (trainer.samples_after_load, trainer.iteration_after_load) == (saved["samples"], saved["iteration"])
    assert record["samples"] == saved["samples"] + 2 * BATCH
    rows = read_metrics(out)
    assert [r["iteration"] for r in rows] == list(range(1, saved["iteration"] + 3)), "iterations lost or repeated"
    assert [r["samples"] for r in rows] == [BATCH * i for i in range(1, saved["iteration"] + 3)]
    assert rows[-1]["asi_version"] >= saved["asi_version"]
    assert f"skipping checkpoint {torn.name}" in caplog.text and "truncated or corrupt" in caplog.text
    assert not leftover.exists()
    assert load_checkpoint(torn)["samples"] == saved["samples"] + 2 * BATCH  # redone and written whole
    print(f"\nresume: killed after {len(rows_at_kill)} recorded iterations, checkpoint at iteration "
          f"{saved['iteration']} ({saved['samples']} samples); rows redone: {len(rows_at_kill) - saved['iteration']}")
