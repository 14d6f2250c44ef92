"""The ASI server or its Redis fails: training survives an outage, refuses a dead store at start.

Real processes throughout: `sfv asi-server` subprocesses on a real redis-server, `sfv train`
subprocesses, and a real RolloutWorker (MuJoCo env, gRPC client) in this process.
"""
from __future__ import annotations

import json
import signal
import threading
import time

import numpy as np
import pytest

from actors.rollout.asi_client import ASIClient
from actors.character.features import observation_dim
from actors.envs.imitation_env import EnvConfig
from actors.motion.formats.io import load_motion
from actors.rollout.worker import RolloutWorker, WorkerSpec
from learner.checkpoint import latest_checkpoint, load_checkpoint
from learner.config import PPOConfig
from learner.errors import SfvError
from learner.ppo import PPOLearner
from services.cli import main
from services.training.config import TrainConfig
from services.training.driver import Trainer
from services.training.run_dir import CONFIG_FILE, checkpoint_files
from tests.asi_helpers import ServerProcess
from tests.redis_fixture import free_port
from tests.integration.test_faults_support import TINY_RUN, TrainProcess, wait_for

OBS_DIM = observation_dim(len(EnvConfig().reference_obs_steps))  # the default env's observation

pytestmark = pytest.mark.integration


@pytest.fixture
def asi_server(tmp_path, redis_server):
    """start(port) -> a listening `sfv asi-server` on the test's Redis; all are stopped after the test."""
    started: list[ServerProcess] = []

    def start(port: int) -> ServerProcess:
        server = ServerProcess(tmp_path / f"asi-{len(started) + 1}.log", "--port", str(port), "--redis-url", redis_server.url)
        started.append(server)
        server.wait_listening()
        return server

    yield start
    for server in started:
        server.stop()  # SIGTERM if still running; reaps and closes its log either way


def kill9(server: ServerProcess) -> None:
    server.process.send_signal(signal.SIGKILL)
    server.wait_exit()


def assert_same_distribution(after, before) -> None:
    assert (after.version, after.pending_episodes) == (before.version, before.pending_episodes)
    for name in ("means", "stds", "phases"):
        np.testing.assert_array_equal(getattr(after, name), getattr(before, name), err_msg=name)


def test_asi_server_killed_twice_mid_run(tmp_path, asi_server):
    """kill -9 #1 while training is paused: the restarted server holds the identical distribution.
    kill -9 #2 while training runs: workers retry, drop and count reports, and carry on after the restart."""
    port = free_port()
    address = f"127.0.0.1:{port}"
    server = asi_server(port)
    iterations = 10
    args = ("--serial", "--workers", "2", "--envs-per-worker", "4", "--init", "asi", "--asi-address", address,
            "--samples", str(iterations * 256), "--asi-outage-s", "60", *TINY_RUN)
    with TrainProcess(tmp_path / "run", *args) as train:
        train.wait_rows(lambda rows: rows and rows[-1]["asi_version"] >= 1, 180, "a first ASI update")
        job = json.loads((train.out / CONFIG_FILE).read_text())["job_id"]

        # 1. Durability: training paused, so nothing writes between the two reads.
        train.send(signal.SIGSTOP)
        with ASIClient(address, job) as client:
            before = client.get_distribution()
        kill9(server)
        server = asi_server(port)
        with ASIClient(address, job) as client:
            assert_same_distribution(client.get_distribution(), before)

        # 2. Outage under load: the server is gone while training runs.
        kill9(server)
        train.send(signal.SIGCONT)
        outage_start = time.monotonic()
        wait_for(lambda: (train.rows() and train.rows()[-1]["asi_dropped_reports"] > 0) or "retrying sample" in train.stderr(),
                 120, "workers noticing the outage", process=train)
        outage_s = time.monotonic() - outage_start
        asi_server(port)
        assert train.wait(300) == 0, train.output()
    rows = train.rows()
    assert [r["samples"] for r in rows] == [256 * i for i in range(1, iterations + 1)]
    dropped = rows[-1]["asi_dropped_reports"]
    assert dropped > 0, "the outage cost no report: it did not overlap one"
    assert rows[-1]["asi_version"] > before.version, "no ASI update after the server came back"
    print(f"\nasi server kill: identical distribution after restart (version {before.version}); "
          f"outage {outage_s:.1f} s until noticed, dropped episodes {dropped}, "
          f"episodes per iteration ~{np.mean([r['episodes'] for r in rows]):.1f}, final asi version {rows[-1]['asi_version']}")


def make_worker(address: str, job: str, outage_s: float) -> tuple[RolloutWorker, dict]:
    motion = load_motion("deepmimic:walk")
    config = TrainConfig(out="unused")
    _, states, phases = Trainer(config)._reference_table(motion)
    with ASIClient(address, job) as client:
        client.create_job(states, phases, num_components=4, episodes_per_update=8)
    spec = WorkerSpec(motion, EnvConfig(), num_envs=4, init="asi", seed=5, asi_address=address, asi_job=job,
                      start_batch=4, asi_outage_s=outage_s)
    worker = RolloutWorker(spec)
    learner = PPOLearner(OBS_DIM, worker.action_dim, PPOConfig(policy_hidden=(64, 32), value_hidden=(64, 32)))
    return worker, learner.policy_weights()


def test_worker_waits_out_an_asi_outage_when_it_needs_starts(asi_server):
    port = free_port()
    address = f"127.0.0.1:{port}"
    server = asi_server(port)
    worker, weights = make_worker(address, "outage", outage_s=60.0)
    worker.sample(weights, 0, 4)  # connected, first starts drawn
    kill9(server)

    # Enough steps that the 4 buffered starts run out while the server is down.
    outcome = {}
    thread = threading.Thread(target=lambda: outcome.update(batch=worker.sample(weights, 1, 150)), daemon=True)
    retries_before = worker.client.retries
    thread.start()
    # Restart only once a whole client.sample() failed (max_retries retries) and the worker kept waiting.
    wait_for(lambda: worker.client.retries > retries_before + worker.client.max_retries, 120, "a failed draw")
    assert thread.is_alive(), "sample() gave up instead of waiting for the server"
    server = asi_server(port)
    thread.join(timeout=120)
    assert not thread.is_alive() and "batch" in outcome
    batch = outcome["batch"]
    assert batch["rewards"].shape == (150, 4) and np.isfinite(batch["rewards"]).all()
    assert len(batch["episode_components"]) > 4, "no episode started from a start drawn after the restart"
    worker.client.close()

    # An outage longer than asi_outage_s ends in SfvError naming the server, within bounded time.
    worker2, _ = make_worker(address, "outage", outage_s=1.0)
    worker2.sample(weights, 0, 4)
    server.stop()
    start = time.monotonic()
    with pytest.raises(SfvError, match=f"asi server {address}: sample failed after"):
        worker2.sample(weights, 1, 150)
    elapsed = time.monotonic() - start
    assert elapsed < 60, elapsed
    print(f"\nworker outage: waited {worker.client.retries - retries_before} client retries; "
          f"gave up {elapsed:.1f} s into a lasting outage (asi_outage_s=1)")


def test_redis_unreachable_at_start_fails_in_seconds(tmp_path, capsys):
    url = f"redis://127.0.0.1:{free_port()}/0"  # nothing listens there
    start = time.monotonic()
    code = main(["train", "--serial", "--workers", "1", "--envs-per-worker", "2", "--init", "asi", "--redis-url", url,
                 "--samples", "256", "--out", str(tmp_path / "run"), *TINY_RUN])
    elapsed = time.monotonic() - start
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert err[0].startswith(f"sfv: redis at {url}: unreachable"), err
    assert elapsed < 10, f"took {elapsed:.1f} s"
    assert checkpoint_files(tmp_path / "run") == []
    print(f"\nredis unreachable at start: exit 2 after {elapsed:.1f} s")


def test_redis_lost_mid_run_stops_training_with_a_clear_error(tmp_path, redis_server):
    """The embedded ASI server loses its Redis: reports are dropped, and once a worker (a Ray actor)
    has waited asi_outage_s for starts, training stops with exit 2 and a message naming Redis; never a hang."""
    args = ("--workers", "1", "--envs-per-worker", "32", "--init", "asi", "--redis-url", redis_server.url,
            "--samples", str(100 * 512), "--asi-outage-s", "3", *TINY_RUN, "--batch-size", "512")
    with TrainProcess(tmp_path / "run", *args) as train:
        train.wait_rows(lambda rows: len(rows) >= 1, 180, "first iteration")
        redis_server.stop()
        lost_at = time.monotonic()
        code = train.wait(180)
        elapsed = time.monotonic() - lost_at
    assert code == 2, train.output()
    message = train.stderr().strip().splitlines()[-1]
    assert message.startswith("sfv: rollout worker 0: asi server "), message
    assert f"redis at {redis_server.url}" in message and "sample failed" in message, message
    rows = train.rows()
    newest = load_checkpoint(latest_checkpoint(train.out))
    assert newest["samples"] == rows[-1]["samples"], "the last recorded iteration was not checkpointed"
    print(f"\nredis lost mid-run: exit 2 after {elapsed:.1f} s, {len(rows)} iterations recorded, "
          f"dropped episodes {rows[-1]['asi_dropped_reports']}; message: {message[:200]}")
