"""Rollout workers as plain objects in the driver's process: no Ray, no pipes (debugging, CI,
a GPU host without Ray). A worker's exception stops training with its own message.
Asynchronous submissions run one at a time when polled: there is no second core to overlap."""
from __future__ import annotations

from services.training.runners.base import WorkerRunner


class InProcessRunner(WorkerRunner):
    name = "in_process"

    def start(self, spec) -> None:
        self.workers = [self.worker_class(spec, i) for i in range(self.config.workers)]
        self._pids = {i: w.pid() for i, w in enumerate(self.workers)}

    def _sample(self, weights, version, steps, options):
        return [w.sample(weights, version, steps, **options) for w in self.workers]

    def submit(self, index, steps, options):
        self._queue = getattr(self, "_queue", [])
        self._queue.append((index, self._published, steps, options))

    def poll(self, timeout):
        if not getattr(self, "_queue", None):
            return []
        index, (weights, version), steps, options = self._queue.pop(0)
        result = self.workers[index].sample(weights, version, steps, **options)
        self._note_pid(index, int(result["worker_pid"]))
        return [(index, result)]
