"""PPO update throughput at the paper's sizes; prints samples/s (a measurement, not a gate)."""

import time

import numpy as np
import pytest
import torch

from learner.config import PPOConfig
from learner.ppo import PPOLearner

OBS_DIM, ACT_DIM = 197, 36


def synthetic_batch(rng, steps=64, envs=64):
    return {
        "obs": rng.normal(size=(steps, envs, OBS_DIM)).astype(np.float32),
        "next_obs": rng.normal(size=(steps, envs, OBS_DIM)).astype(np.float32),
        "actions": rng.normal(scale=0.1, size=(steps, envs, ACT_DIM)).astype(np.float32),
        "logp": rng.normal(30.0, 1.0, size=(steps, envs)).astype(np.float32),
        "rewards": rng.random((steps, envs)).astype(np.float32),
        "terminated": rng.random((steps, envs)) < 0.01,
        "truncated": np.zeros((steps, envs), bool),
    }


@pytest.fixture
def one_torch_thread():
    """Measured on one thread: on a shared 2-core runner two spinning OpenMP threads are
    several times slower than one, so one thread gives the steadier number."""
    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(previous)


def test_update_throughput_batch_4096_minibatch_256(capsys, one_torch_thread):
    # target_kl off so that every update runs all epochs * 16 minibatch steps.
    config = PPOConfig(batch_size=4096, minibatch_size=256, target_kl=None)
    learner = PPOLearner(OBS_DIM, ACT_DIM, config)
    rng = np.random.default_rng(0)
    learner.update(synthetic_batch(rng, steps=4))  # first update: lazy allocations, normaliser fit
    batch = synthetic_batch(rng)
    start = time.perf_counter()
    metrics = learner.update(batch)
    seconds = time.perf_counter() - start
    steps = int(metrics["charts/gradient_steps"])
    assert steps == config.update_epochs * 16
    assert all(np.isfinite(value) for key, value in metrics.items() if key != "losses/explained_variance")
    with capsys.disabled():
        print(
            f"\nPPO update, batch 4096, minibatch 256, {config.update_epochs} epochs ({steps} steps), "
            f"obs {OBS_DIM} act {ACT_DIM}, 1024-512 nets, {torch.get_num_threads()} torch threads: "
            f"{seconds:.2f} s = {4096 / seconds:.0f} samples/s"
        )
