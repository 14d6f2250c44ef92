"""NaN / inf in observations, rewards or gradients: the iteration is rejected, training stops cleanly.

Serial in-process runs through the real `sfv train` entry point (services.cli.main): the real
worker samples the real env, then this test's subclass poisons one value of its second batch.
"""
from __future__ import annotations

import numpy as np
import pytest

from actors.rollout.worker import RolloutWorker
from learner.checkpoint import latest_checkpoint, load_checkpoint
from services.cli import main
from services.training.driver import Trainer
from services.training.run_dir import checkpoint_files, read_metrics
from tests.integration.test_faults_support import TINY_RUN

pytestmark = pytest.mark.integration

# (array, value, what the message must name). 3e38 is a finite float32 action whose squared
# distance to the policy mean overflows: finite batch, non-finite policy gradient.
POISONS = {
    "nan_observation": ("obs", np.nan, "batch['obs']"),
    "inf_reward": ("rewards", np.inf, "batch['rewards']"),
    "gradient_overflow": ("actions", 3e38, "gradients of the policy network"),
}


def poisoned_worker(array: str, value: float, at_version: int = 1):
    class PoisonedWorker(RolloutWorker):
        def sample(self, weights, policy_version, steps, **options):
            batch = super().sample(weights, policy_version, steps, **options)
            if policy_version == at_version:
                target = batch[array]
                target[(steps // 2, 0) + (0,) * (target.ndim - 2)] = value  # one entry of env 0's middle step
            return batch

    return PoisonedWorker


@pytest.mark.parametrize("poison", sorted(POISONS))
def test_poisoned_batch_stops_training_before_any_checkpoint(poison, tmp_path, monkeypatch, capsys):
    array, value, named = POISONS[poison]
    monkeypatch.setattr(Trainer, "worker_class", poisoned_worker(array, value))
    out = tmp_path / "run"
    code = main(["train", "--serial", "--workers", "1", "--envs-per-worker", "4", "--init", "rsi",
                 "--samples", str(4 * 256), "--out", str(out), *TINY_RUN])
    stderr = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    message = stderr[-1]
    assert message.startswith("sfv: ") and "non-finite" in message and named in message, message
    assert "iteration 2 rejected" in message and "checkpoint_000000001.pt" in message, message
    # Iteration 1 was recorded and checkpointed; nothing of the poisoned iteration 2 was.
    assert [r["iteration"] for r in read_metrics(out)] == [1]
    assert [p.name for p in checkpoint_files(out)] == ["checkpoint_000000001.pt"]
    checkpoint = load_checkpoint(latest_checkpoint(out))
    assert checkpoint["samples"] == 256
    for name, tensor in checkpoint["learner"]["policy"].items():
        assert np.isfinite(tensor.numpy()).all(), name
