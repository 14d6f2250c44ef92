"""The task rollout worker: `RolloutWorker`'s `sample()` contract over task envs.

Only the env differs from imitation: no reference, no ASI server, starts drawn inside the env.
`sample()` is inherited, so the training runners (Ray actors, in-process, processes) carry
task workers unchanged and the PPO learner sees the same time-major arrays.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from actors.rollout.worker import RolloutWorker
from actors.envs.tasks.config import TaskEnvConfig
from actors.envs.tasks.vector_task_env import VectorTaskEnv


@dataclass(frozen=True)
class TaskWorkerSpec:
    """Everything a task worker needs to build itself (picklable; Ray re-runs it on restart)."""

    env: TaskEnvConfig
    num_envs: int
    seed: int
    gamma: float = 0.95
    init: str = "task"  # not "asi": sample() never reports episodes to a server


class TaskRolloutWorker(RolloutWorker):
    def __init__(self, spec: TaskWorkerSpec, worker_index: int = 0):
        from threadpoolctl import threadpool_limits

        threadpool_limits(1, user_api="blas")  # as RolloutWorker: one BLAS thread beside MuJoCo
        self.spec = spec
        self.worker_index = worker_index
        self.seed = spec.seed + worker_index
        self.rng = np.random.default_rng(self.seed)
        self.client = None
        self.env = VectorTaskEnv(spec.env, spec.num_envs, seed=self.seed * 1000, gamma=spec.gamma)
        self.policy = None
        self._weights = None
        self._started = False
        self.asi_version = 0
