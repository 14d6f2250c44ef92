"""A rollout worker that replays the first batch it sampled: the synthetic workers of the scaling
suite, which measure what the driver and learner can consume when sampling costs nothing (the
ceiling that no number of cores can lift). Only the policy version and the worker's identity
change between replays; episodes, rewards and observations repeat."""
from __future__ import annotations

import os
import time

import numpy as np

from actors.rollout.worker import RolloutWorker


class RecordedWorker(RolloutWorker):
    def __init__(self, spec, worker_index: int = 0):
        super().__init__(spec, worker_index)
        self._recorded: dict | None = None

    def sample(self, weights: dict, policy_version: int, steps: int, horizon_s: float | None = None) -> dict:
        if self._recorded is None or self._recorded["obs"].shape[0] != steps:
            self._recorded = super().sample(weights, policy_version, steps, horizon_s)
        batch = dict(self._recorded)
        batch["policy_version"] = np.array(policy_version)
        batch["worker_pid"] = np.array(os.getpid())
        batch["sample_seconds"] = np.array(0.0)
        return batch


class PacedWorker(RecordedWorker):
    """A replaying worker that takes as long as a real one sampling `samples_per_s` would: a core
    of a bigger machine, emulated by a process that sleeps instead of stepping physics. Many of
    them measure how the driver and learner of *this* machine keep up with more workers than it
    has cores (`sfv bench --suite scaling --scaling-paced-rate R`)."""

    def __init__(self, spec, worker_index: int = 0, samples_per_s: float = 2000.0):
        super().__init__(spec, worker_index)
        if not samples_per_s > 0:
            raise ValueError(f"a paced worker needs a positive rate, got {samples_per_s}")
        self.samples_per_s = float(samples_per_s)

    def sample(self, weights: dict, policy_version: int, steps: int, horizon_s: float | None = None) -> dict:
        started = time.perf_counter()
        batch = super().sample(weights, policy_version, steps, horizon_s)
        due = batch["rewards"].size / self.samples_per_s - (time.perf_counter() - started)
        if due > 0:
            time.sleep(due)
        batch["sample_seconds"] = np.array(time.perf_counter() - started)
        return batch
