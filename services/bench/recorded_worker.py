"""A rollout worker that replays the first batch it sampled: the synthetic workers of the scaling
suite, which measure what the driver and learner can consume when sampling costs nothing (the
ceiling that no number of cores can lift). Only the policy version and the worker's identity
change between replays; episodes, rewards and observations repeat."""
from __future__ import annotations

import os

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
