"""The asynchronous loop's sampling side: no wait on stragglers, bounded policy lag, lost shares
handed out again."""
from __future__ import annotations

import pytest

from learner.errors import SfvError
from services.training.async_collector import AsyncCollector
from services.training.runners.base import WorkerFaults, WorkerRunner


class ScriptedRunner(WorkerRunner):
    """Workers whose shares finish in a scripted order: `script` is a list of worker indices (or
    (index, None) for a lost share), one entry consumed per poll."""

    def __init__(self, workers: int, script: list):
        super().__init__(None, None, WorkerFaults())
        self.workers = list(range(workers))
        self.script = list(script)
        self.in_flight: dict[int, int] = {}  # worker -> version of the weights it samples with
        self.submissions: list[tuple[int, int]] = []

    def start(self, spec):
        pass

    def _sample(self, weights, version, steps, options):
        raise AssertionError("the asynchronous loop never calls collect")

    def submit(self, index, steps, options):
        assert index not in self.in_flight, "two shares in flight on one worker"
        self.in_flight[index] = self._published[1]
        self.submissions.append((index, self._published[1]))

    def poll(self, timeout):
        entry = self.script.pop(0)
        index, lost = (entry[0], True) if isinstance(entry, tuple) else (entry, False)
        version = self.in_flight.pop(index)
        return [(index, None if lost else {"worker_index": index, "policy_version": version})]


def test_a_batch_takes_whichever_shares_are_ready_and_never_waits_for_a_straggler():
    runner = ScriptedRunner(2, script=[0, 0])  # worker 1 is slow: worker 0 finishes twice first
    collector = AsyncCollector(runner, steps=4, max_lag=1, shares_per_batch=2, timeout_s=1.0)
    batch = collector.next_batch({}, 0, {})
    assert [share["worker_index"] for share in batch] == [0, 0]
    assert runner.submissions == [(0, 0), (1, 0), (0, 0), (0, 0)]  # worker 0 went straight back to work each time


def test_shares_drawn_by_weights_older_than_the_lag_bound_are_dropped():
    runner = ScriptedRunner(2, script=[0, 0, 0, 0, 1, 0, 1])
    collector = AsyncCollector(runner, steps=4, max_lag=1, shares_per_batch=2, timeout_s=1.0)
    collector.next_batch({}, 0, {})  # worker 1's first share is still drawing with version 0
    collector.next_batch({}, 1, {})
    third = collector.next_batch({}, 2, {})  # worker 1's version-0 share arrives now: two versions old
    assert collector.stale_shares == 1
    assert all(2 - share["policy_version"] <= 1 for share in third)


def test_a_lost_share_is_handed_out_again_and_endless_losses_stop_the_run(monkeypatch):
    monkeypatch.setattr("services.training.async_collector.time.sleep", lambda s: None)
    runner = ScriptedRunner(2, script=[(0, None), 0, 1])
    collector = AsyncCollector(runner, steps=4, max_lag=1, shares_per_batch=2, timeout_s=1.0)
    assert sorted(share["worker_index"] for share in collector.next_batch({}, 0, {})) == [0, 1]
    failing = ScriptedRunner(2, script=[(0, None), (1, None)] * 10)
    with pytest.raises(SfvError, match="in a row"):
        AsyncCollector(failing, steps=4, max_lag=1, shares_per_batch=2, timeout_s=1.0).next_batch({}, 0, {})
