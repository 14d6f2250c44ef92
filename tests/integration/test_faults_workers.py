"""Rollout workers that die or hang in the middle of sample(): training goes on to its budget.

One real `sfv train` subprocess on local Ray with 2 worker actors. A victim is found by its
process title (Ray names a busy actor process `ray::RolloutWorker.sample`), so each fault
lands while a share of the batch is being collected:
- SIGKILL: the actor dies; Ray restarts it; its share is reissued.
- SIGSTOP: the actor hangs; after --worker-timeout-s the driver kills it (Ray restarts it)
  and reissues its share.
The synchronous loop (the default) and the asynchronous one (--max-policy-lag 1): there, the other
worker fills the batches while one restarts, and a hung worker is found by its own share's
deadline, so the run is stopped (SIGTERM) once both faults are handled instead of ending at a
budget it could reach without the hung worker.
"""
from __future__ import annotations

import os
import signal

import pytest

from learner.checkpoint import latest_checkpoint, load_checkpoint
from tests.integration.test_faults_support import TINY_RUN, TrainProcess, cmdline, descendants, wait_for

pytestmark = pytest.mark.integration

BATCH = 512  # 256 samples per worker: a sample() call lasts long enough to be hit
TIMEOUT_S = 15  # --worker-timeout-s: several times an iteration, even on a loaded machine


def busy_worker(train: TrainProcess) -> int | None:
    return next((pid for pid in descendants(train.pid) if cmdline(pid).startswith("ray::RolloutWorker.sample")), None)


def hit_busy_worker(train: TrainProcess, signum: int) -> int:
    victim = wait_for(lambda: busy_worker(train), 60, "a rollout worker inside sample()", interval=0.01, process=train)
    os.kill(victim, signum)
    return victim


def test_workers_killed_or_hung_mid_sample_are_restarted_and_their_shares_reissued(tmp_path):
    iterations, lag = 6, 0
    args = ("--workers", "2", "--envs-per-worker", "4", "--init", "asi", "--samples", str(iterations * BATCH),
            *TINY_RUN, "--batch-size", str(BATCH), "--worker-timeout-s", str(TIMEOUT_S), "--max-policy-lag", str(lag))
    with TrainProcess(tmp_path / "run", *args) as train:
        train.wait_rows(lambda rows: len(rows) >= 1, 180, "first iteration")
        killed = hit_busy_worker(train, signal.SIGKILL)
        rows = train.wait_rows(lambda rows: rows and rows[-1]["worker_failures"] >= 1, 120, "the kill recorded")
        killed_at = rows[-1]["iteration"]
        hung = hit_busy_worker(train, signal.SIGSTOP)
        assert train.wait(300) == 0, train.output()

    rows = train.rows()
    assert [r["iteration"] for r in rows] == list(range(1, iterations + 1))
    assert rows[-1]["samples"] == iterations * BATCH, "training stopped short of its sample budget"
    assert killed_at >= 2, "the kill came after iteration 1 was recorded"
    hang_row = next(r for r in rows if r["worker_failures"] > rows[killed_at - 1]["worker_failures"])
    assert rows[-1]["worker_restarts"] >= 2, rows[-1]
    assert f"no answer within {TIMEOUT_S:g} s, killed" in train.stderr()
    for r in rows:
        # One policy version per batch, the one of this iteration; two shares whoever sampled them.
        assert r["batch_policy_versions"] == [r["iteration"] - 1] == [r["policy_version"]], r
        assert len(r["batch_worker_indices"]) == 2, r
        assert r["samples"] == r["iteration"] * BATCH
    for victim in (killed, hung):  # both processes are gone (the hung one killed by the driver)
        assert not os.path.exists(f"/proc/{victim}") or "RolloutWorker" not in cmdline(victim)
    checkpoint = load_checkpoint(latest_checkpoint(train.out))
    assert checkpoint["samples"] == iterations * BATCH and checkpoint["worker_restarts"] >= 2
    seconds = [round(BATCH / r["samples_per_s"], 1) for r in rows]
    print(f"\nworker faults: killed in iteration {killed_at} (shares {rows[killed_at - 1]['batch_worker_indices']}), "
          f"hung in iteration {hang_row['iteration']} (shares {hang_row['batch_worker_indices']}); "
          f"failures={rows[-1]['worker_failures']} restarts={rows[-1]['worker_restarts']}; iteration seconds={seconds}")


def test_asynchronous_loop_goes_on_while_a_killed_or_hung_worker_is_restarted(tmp_path):
    lag = 1
    args = ("--workers", "2", "--envs-per-worker", "4", "--init", "asi", "--samples", str(10_000 * BATCH),
            *TINY_RUN, "--batch-size", str(BATCH), "--worker-timeout-s", str(TIMEOUT_S), "--max-policy-lag", str(lag))
    with TrainProcess(tmp_path / "run", *args) as train:
        train.wait_rows(lambda rows: len(rows) >= 1, 180, "first iteration")
        killed = hit_busy_worker(train, signal.SIGKILL)
        train.wait_rows(lambda rows: rows and rows[-1]["worker_restarts"] >= 1, 120, "the killed worker's restart counted")
        hung = hit_busy_worker(train, signal.SIGSTOP)
        before = len(train.rows())
        rows = train.wait_rows(lambda rows: rows and rows[-1]["worker_restarts"] >= 2, 120 + TIMEOUT_S, "the hung worker found and restarted")
        os.kill(train.pid, signal.SIGTERM)
        assert train.wait(120) == 128 + signal.SIGTERM, train.output()

    rows = train.rows()
    assert f"no answer within {TIMEOUT_S:g} s, killed" in train.stderr()
    assert len(rows) > before + 1, "training went on while the hung worker waited for its deadline"
    assert [r["iteration"] for r in rows] == list(range(1, len(rows) + 1))
    for r in rows:  # up to --max-policy-lag versions old; two shares, whoever sampled them
        assert all(r["iteration"] - 1 - lag <= v <= r["iteration"] - 1 for v in r["batch_policy_versions"]), r
        assert len(r["batch_worker_indices"]) == 2 and r["samples"] == r["iteration"] * BATCH, r
    for victim in (killed, hung):
        assert not os.path.exists(f"/proc/{victim}") or "RolloutWorker" not in cmdline(victim)
    checkpoint = load_checkpoint(latest_checkpoint(train.out))
    assert checkpoint["samples"] == rows[-1]["samples"] and checkpoint["worker_restarts"] >= 2
