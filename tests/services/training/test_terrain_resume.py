"""A terrain training's curriculum across `--resume`: the checkpoint keeps the envs' mean level
and the resumed run's workers start every env there (a fresh run's start on flat ground)."""
from __future__ import annotations

import logging

import numpy as np
import pytest

from actors.envs.imitation_env import EnvConfig
from actors.rollout.worker import RolloutWorker
from learner.checkpoint import latest_checkpoint, load_checkpoint, save_checkpoint
from services.training.config import TrainConfig
from services.training.driver import Trainer

BATCH = 128


class RecordingWorker(RolloutWorker):
    """Keeps, per worker built, the envs' curriculum levels and difficulties it starts with, and
    the levels each `sample` returns."""

    built: list = []
    returned: list = []

    def __init__(self, spec, worker_index=0):
        super().__init__(spec, worker_index)
        RecordingWorker.built.append((self.env.terrain_levels().tolist(), [env.terrain_difficulty for env in self.env.envs]))

    def sample(self, *args, **kwargs):
        batch = super().sample(*args, **kwargs)
        RecordingWorker.returned.append(batch["terrain_levels"].copy())
        return batch


class RecordingTrainer(Trainer):
    worker_class = RecordingWorker


def _config(out, samples: int) -> TrainConfig:
    config = TrainConfig(motion="deepmimic:walk", out=str(out), workers=1, envs_per_worker=4, init="rsi", samples=samples,
                         runner="in_process", checkpoint_every=1, plot_every=0, eval_every=0, torch_threads=1,
                         env=EnvConfig(terrain="mixed", terrain_difficulty=0.5, horizon_s=1.0))
    config.ppo.batch_size = config.ppo.minibatch_size = BATCH
    config.ppo.policy_hidden = config.ppo.value_hidden = (16,)
    return config


def test_a_resumed_terrain_run_starts_its_envs_at_the_checkpoints_level(tmp_path, caplog):
    RecordingWorker.built, RecordingWorker.returned = [], []
    out = tmp_path / "run"
    RecordingTrainer(_config(out, BATCH), progress=False).run()
    assert RecordingWorker.built == [([0] * 4, [0.0] * 4)]  # a fresh run: flat ground, as before
    path = latest_checkpoint(out)
    saved = load_checkpoint(path)
    assert saved["terrain_level"] == pytest.approx(float(np.mean(RecordingWorker.returned[-1])))

    # As a run that had climbed: the envs' mean level 4.4 when the checkpoint was taken.
    save_checkpoint(path, {**saved, "terrain_level": 4.4})
    RecordingWorker.built = []
    with caplog.at_level(logging.INFO, logger="sfv.train"):
        record = RecordingTrainer(_config(out, 2 * BATCH), resume=True, progress=False).run()
    assert record["samples"] == 2 * BATCH
    assert RecordingWorker.built == [([4] * 4, [pytest.approx(0.2)] * 4)]
    assert "terrain curriculum: resuming at level 4 (difficulty 0.20)" in caplog.text
    assert load_checkpoint(latest_checkpoint(out))["terrain_level"] == pytest.approx(float(np.mean(RecordingWorker.returned[-1])))
