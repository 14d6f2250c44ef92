"""The processes runner starts a dead worker process again and hands it its share again, in the
synchronous and the asynchronous interface."""
from __future__ import annotations

import logging
import os
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from services.training.runners import ProcessRunner, WorkerFaults


class DiesOnceWorker:
    """Worker 0's process dies (no error sent) on its first sample(); a file remembers it did."""

    def __init__(self, spec, index: int):
        self.marker, self.index = Path(spec["marker"]), index

    def pid(self) -> int:
        return os.getpid()

    def sample(self, weights, version, steps, **options):
        if self.index == 0 and not self.marker.exists():
            self.marker.write_text("died")
            os._exit(9)
        return {"worker_index": np.array(self.index), "worker_pid": np.array(os.getpid()), "policy_version": np.array(version)}


def _runner(tmp_path, name):
    runner = ProcessRunner(SimpleNamespace(workers=2), DiesOnceWorker, WorkerFaults())
    runner.start({"marker": str(tmp_path / name)})
    return runner


def test_a_dead_worker_process_is_replaced_and_its_share_collected(tmp_path, caplog):
    runner = _runner(tmp_path, "sync")
    try:
        with caplog.at_level(logging.WARNING, logger="sfv.train"):
            results = runner.collect({}, 0, 1, {})
        assert sorted(int(r["worker_index"]) for r in results) == [0, 1]
        assert runner.faults.restarts == 1 and runner.faults.failures == 1
        assert any("started again" in r.getMessage() for r in caplog.records)
        runner.collect({}, 1, 1, {})
        assert runner.faults.restarts == 1  # the new process answering is not another restart
    finally:
        runner.close()


def test_the_asynchronous_interface_reports_the_lost_share_and_the_worker_works_again(tmp_path):
    runner = _runner(tmp_path, "async")
    try:
        runner.publish({}, 0)
        runner.submit(0, 1, {})
        runner.submit(1, 1, {})
        done = []
        while len(done) < 2:
            done += runner.poll(60.0)
        assert dict(done)[0] is None and int(dict(done)[1]["worker_index"]) == 1
        runner.submit(0, 1, {})
        (index, share), = runner.poll(60.0)
        assert index == 0 and int(share["worker_index"]) == 0 and runner.faults.restarts == 1
    finally:
        runner.close()
