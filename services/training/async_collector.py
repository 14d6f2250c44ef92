"""The sampling side of the asynchronous actor-learner loop (`--max-policy-lag K`, K >= 1), in
the manner of sample-factory's APPO and IMPALA: every worker always has a share in flight, so
the workers keep sampling while the learner updates, instead of idling through each update as
in the synchronous loop (0.4 s of every 1.03-s iteration on 2 cores, 2 workers).

- A finished share is handed straight back to its worker with the newest published weights;
  the weights are published (Ray: put in the object store) once per version.
- A batch is the first `shares_per_batch` shares that are done, whichever workers drew them:
  no wait on a straggler (a fast worker may give two shares to one batch).
- Policy lag: the update that starts from version v learns from shares drawn by versions
  v - lag. A share older than `max_lag` versions is dropped and counted (`stale_shares`), so the
  lag stays bounded; the learner corrects for the lag it has (`learner/ppo.py`,
  `decoupled_surrogate_loss`).
- A share lost to a dead or hung worker is counted by the runner and the worker (restarted by
  it) gets a new share; a worker that keeps failing stops the run.
"""
from __future__ import annotations

import time

from learner.errors import SfvError
from services.training.runners.base import WorkerRunner

FAILURES_BEFORE_BACKOFF = 2  # a share that fails again at once: the worker is still being restarted


class AsyncCollector:
    def __init__(self, runner: WorkerRunner, steps: int, max_lag: int, shares_per_batch: int, timeout_s: float):
        if max_lag < 1:
            raise SfvError(f"internal: the asynchronous loop needs a policy lag of at least 1, got {max_lag}")
        self.runner, self.steps, self.max_lag = runner, steps, max_lag
        self.shares_per_batch, self.timeout_s = shares_per_batch, timeout_s
        self.workers = len(runner.workers)
        self.ready: list[dict] = []  # finished shares not yet in a batch
        self.stale_shares = 0  # dropped: drawn by weights more than max_lag versions old
        self._failures = [0] * self.workers  # consecutive lost shares per worker
        self._started = False
        self._options: dict = {}

    def next_batch(self, weights: dict, version: int, options: dict) -> list[dict]:
        """The shares of the update that starts from `weights` (version `version`); `options` go
        with every share submitted from now on (the curriculum's horizon)."""
        self.runner.publish(weights, version)
        self._options = options
        if not self._started:
            for index in range(self.workers):
                self.runner.submit(index, self.steps, options)
            self._started = True
        self._drop_stale(version)
        while len(self.ready) < self.shares_per_batch:
            for index, share in self.runner.poll(self.timeout_s):
                self._received(index, share, version)
        batch, self.ready = self.ready[: self.shares_per_batch], self.ready[self.shares_per_batch:]
        return batch

    def _received(self, index: int, share: dict | None, version: int) -> None:
        if share is None:
            self._failures[index] += 1
            if sum(self._failures) > 3 * self.workers:
                raise SfvError(f"rollout workers lost {sum(self._failures)} shares in a row before update {version + 1}, giving up")
            if self._failures[index] >= FAILURES_BEFORE_BACKOFF:
                time.sleep(min(5.0, 0.5 * 2 ** (self._failures[index] - FAILURES_BEFORE_BACKOFF)))
        else:
            self._failures[index] = 0
            if version - int(share["policy_version"]) > self.max_lag:
                self.stale_shares += 1
            else:
                self.ready.append(share)
        self.runner.submit(index, self.steps, self._options)  # straight back to work, with the newest weights

    def _drop_stale(self, version: int) -> None:
        fresh = [share for share in self.ready if version - int(share["policy_version"]) <= self.max_lag]
        self.stale_shares += len(self.ready) - len(fresh)
        self.ready = fresh
