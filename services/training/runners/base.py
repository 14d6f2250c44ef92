"""The interface between the training driver and its rollout workers, whatever carries them.

A runner starts `config.workers` rollout workers from one `WorkerSpec`, hands each the same
weights and step count per iteration, and returns their batches; it counts the shares lost to
failing workers and the worker processes seen replaced. Three transports implement it
(sample-factory's `runner_serial` / `runner_parallel` split): `InProcessRunner` (this
process, no Ray), `RayRunner` (Ray actors, fault tolerant) and `ProcessRunner` (spawned
processes over pipes, for hosts without Ray).

Two ways to drive them: `collect` (the synchronous loop: every worker samples with this
iteration's weights, the driver waits for all) and, for the asynchronous loop
(`services/training/async_collector.py`), `publish` (the newest weights, put once per version)
with `submit` (one worker starts a share with the published weights) and `poll` (the shares
that are done, None for one lost to a failing worker).
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
    ray_restarts: int = 0  # the local Ray started again after its raylet or GCS died


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

    # ------------------------------------------------------- the asynchronous interface
    def publish(self, weights: dict, version: int) -> None:
        """The weights later `submit` calls hand out (Ray: put in the object store once)."""
        self._published = (weights, version)

    @abstractmethod
    def submit(self, index: int, steps: int, options: dict) -> None:
        """Worker `index` starts a share with the published weights; at most one per worker."""

    @abstractmethod
    def poll(self, timeout: float) -> list[tuple[int, dict | None]]:
        """(worker index, share) for each submitted share done within `timeout` seconds, at least
        one unless nothing is pending; a share lost to a dead or hung worker comes back as None
        (the worker is being restarted and can be submitted to again)."""

    def close(self) -> None:
        """Stop the workers this runner started (Ray actors go with the Ray session)."""

    def _note_pid(self, index: int, pid: int) -> None:
        previous = self._pids.get(index)
        if previous is not None and previous != pid:
            self.faults.restarts += 1
            log.warning("rollout worker %d was restarted (pid %d -> %d)", index, previous, pid)
        self._pids[index] = pid
