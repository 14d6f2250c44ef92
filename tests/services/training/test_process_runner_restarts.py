"""The processes runner starts a dead or hung worker process again and hands it its share again,
in the synchronous and the asynchronous interface."""
from __future__ import annotations

import logging
import os
import signal
import time
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


class HangsOnceWorker(DiesOnceWorker):
    """Worker 0's process stops itself (SIGSTOP: alive, silent) on its first sample()."""

    def sample(self, weights, version, steps, **options):
        if self.index == 0 and not self.marker.exists():
            self.marker.write_text(str(os.getpid()))
            os.kill(os.getpid(), signal.SIGSTOP)
        return super().sample(weights, version, steps, **options)


TIMEOUT_S = 3.0  # a share of these workers takes milliseconds


def _runner(tmp_path, name, worker_class=DiesOnceWorker):
    runner = ProcessRunner(SimpleNamespace(workers=2, worker_timeout_s=TIMEOUT_S), worker_class, WorkerFaults())
    runner.start({"marker": str(tmp_path / name)})
    return runner


def _gone(pid: int) -> bool:
    """The process is reaped, or a zombie nobody waits for."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] == "Z"
    except FileNotFoundError:
        return True


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


def test_a_hung_worker_is_killed_at_its_deadline_and_its_share_sent_again(tmp_path, caplog):
    runner = _runner(tmp_path, "hung_sync", HangsOnceWorker)
    try:
        started = time.monotonic()
        with caplog.at_level(logging.WARNING, logger="sfv.train"):
            results = runner.collect({}, 0, 1, {})
        assert time.monotonic() - started >= TIMEOUT_S, "the hung worker was given up on before its deadline"
        assert sorted(int(r["worker_index"]) for r in results) == [0, 1]
        assert runner.faults.restarts == 1 and runner.faults.failures == 1
        assert any(f"no answer within {TIMEOUT_S:g} s, killed" in r.getMessage() for r in caplog.records)
        assert _gone(int((tmp_path / "hung_sync").read_text()))
    finally:
        runner.close()


def test_the_asynchronous_interface_finds_a_hung_worker_while_the_other_answers(tmp_path):
    runner = _runner(tmp_path, "hung_async", HangsOnceWorker)
    try:
        runner.publish({}, 0)
        runner.submit(0, 1, {})
        runner.submit(1, 1, {})
        order = []
        while len(order) < 2 or 0 not in [index for index, _ in order]:
            for index, share in runner.poll(TIMEOUT_S):
                order.append((index, share))
                if index == 1:
                    runner.submit(1, 1, {})  # the healthy worker goes on sampling
        answers = [index for index, share in order if share is not None]
        assert answers.count(1) >= 1 and (0, None) in order, order
        assert order.index((0, None)) > 0, "the healthy worker's share came first"
        assert runner.faults.failures == 1 and runner.faults.restarts == 1
        assert _gone(int((tmp_path / "hung_async").read_text()))
        runner.submit(0, 1, {})
        done = []
        while not any(index == 0 for index, _ in done):
            done += runner.poll(TIMEOUT_S)
        assert int(dict(done)[0]["worker_index"]) == 0 and runner.faults.restarts == 1
    finally:
        runner.close()
