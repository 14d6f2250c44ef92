"""The interface between the training driver and its rollout workers, whatever carries them.

A runner starts `config.workers` rollout workers from one `WorkerSpec`, hands each the same
weights and step count per iteration, and returns their batches; it counts the shares lost to
failing workers and the worker processes seen replaced. Three transports implement it
(sample-factory's `runner_serial` / `runner_parallel` split): `InProcessRunner` (this
process, no Ray), `RayRunner` (Ray actors, fault tolerant) and `ProcessRunner` (spawned
processes over pipes, for hosts without Ray).
"""
from __future__ import annotations

import logging
from abc import ABC, abstractmethod
from dataclasses import dataclass

log = logging.getLogger("sfv.train")


@dataclass
class WorkerFaults:
    """Counters the driver records in metrics.jsonl and carries across --resume."""

    failures: int = 0  # batch shares lost to a dead, hung or failing worker and reissued
    restarts: int = 0  # worker processes replaced (Ray: its per-actor restart count; otherwise a new pid)


class WorkerRunner(ABC):
    def __init__(self, config, worker_class, faults: WorkerFaults):
        self.config = config
        self.worker_class = worker_class  # RolloutWorker, or a test's subclass of it
        self.faults = faults
        self._pids: dict[int, int] = {}
        self.workers: list = []  # what start() built: worker objects, Ray actor handles or process pipes

    @abstractmethod
    def start(self, spec) -> None:
        """Build the workers; construction errors surface here, before the first iteration."""

    @abstractmethod
    def _sample(self, weights: dict, version: int, steps: int, options: dict) -> list[dict]:
        """One batch from every worker (or from a stand-in for a lost one)."""

    def collect(self, weights: dict, version: int, steps: int, options: dict) -> list[dict]:
        """`RolloutWorker.sample` on every worker with these weights; `options` are its
        optional arguments (the curriculum's `horizon_s`)."""
        results = self._sample(weights, version, steps, options)
        for result in results:
            self._note_pid(int(result["worker_index"]), int(result["worker_pid"]))
        return results

    def close(self) -> None:
        """Stop the workers this runner started (Ray actors go with the Ray session)."""

    def _note_pid(self, index: int, pid: int) -> None:
        previous = self._pids.get(index)
        if previous is not None and previous != pid:
            self.faults.restarts += 1
            log.warning("rollout worker %d was restarted (pid %d -> %d)", index, previous, pid)
        self._pids[index] = pid
