"""Transports between the training driver and its rollout workers, one interface
(`WorkerRunner`): in this process, as Ray actors, or as plain processes."""
from __future__ import annotations

from services.training.runners.base import WorkerFaults, WorkerRunner
from services.training.runners.in_process import InProcessRunner
from services.training.runners.processes import ProcessRunner
from services.training.runners.ray_actors import RayRunner

RUNNERS: dict[str, type[WorkerRunner]] = {r.name: r for r in (RayRunner, InProcessRunner, ProcessRunner)}


def make_runner(config, worker_class, faults: WorkerFaults) -> WorkerRunner:
    return RUNNERS[config.runner](config, worker_class, faults)


__all__ = ["RUNNERS", "InProcessRunner", "ProcessRunner", "RayRunner", "WorkerFaults", "WorkerRunner", "make_runner"]
