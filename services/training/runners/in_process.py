"""Rollout workers as plain objects in the driver's process: no Ray, no pipes (debugging, CI,
a GPU host without Ray). A worker's exception stops training with its own message."""
from __future__ import annotations

from services.training.runners.base import WorkerRunner


class InProcessRunner(WorkerRunner):
    name = "in_process"

    def start(self, spec) -> None:
        self.workers = [self.worker_class(spec, i) for i in range(self.config.workers)]
        self._pids = {i: w.pid() for i, w in enumerate(self.workers)}

    def _sample(self, weights, version, steps, options):
        return [w.sample(weights, version, steps, **options) for w in self.workers]
