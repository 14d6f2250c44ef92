"""End-to-end training with 2 real Ray workers, a real gRPC ASI server and a real Redis."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from learner.checkpoint import latest_checkpoint, load_checkpoint
from services.training.config import TrainConfig
from services.training.driver import Trainer
from services.training.run_dir import read_metrics

pytestmark = pytest.mark.integration


def small_config(out: Path, **overrides) -> TrainConfig:
    config = TrainConfig(motion="deepmimic:walk", out=str(out), workers=2, envs_per_worker=4, init="asi",
                         samples=3 * 256, seed=3, asi_episodes_per_update=8, checkpoint_every=1, plot_every=0)
    config.ppo.batch_size = 256
    config.ppo.minibatch_size = 128
    config.ppo.policy_hidden = (64, 32)
    config.ppo.value_hidden = (64, 32)
    for key, value in overrides.items():
        setattr(config, key, value)
    return config


@pytest.fixture(scope="module")
def ray_local():
    import ray

    ray.init(num_cpus=2, include_dashboard=False, configure_logging=False, log_to_driver=False)
    yield
    ray.shutdown()


@pytest.mark.slow
def test_two_workers_with_redis_asi_then_resume(tmp_path, redis_url, ray_local):
    out = tmp_path / "run"
    record = Trainer(small_config(out, redis_url=redis_url), progress=False).run()
    rows = read_metrics(out)
    assert [r["iteration"] for r in rows] == [1, 2, 3]
    assert [r["samples"] for r in rows] == [256, 512, 768]
    assert rows[-1]["asi_version"] > 0, "ASI distribution never updated"
    assert record["samples"] == 768
    assert all(r["episodes"] > 0 and 0.0 <= r["normalized_return"] <= 1.0 for r in rows)
    assert (out / "tb").is_dir() and any((out / "tb").iterdir())
    checkpoint = load_checkpoint(latest_checkpoint(out))
    assert checkpoint["samples"] == 768 and checkpoint["asi_version"] == rows[-1]["asi_version"]

    # Resume: the sample count continues from the checkpoint, the ASI job (in Redis) too.
    Trainer(small_config(out, redis_url=redis_url, samples=5 * 256), resume=True, progress=False).run()
    rows = read_metrics(out)
    assert [r["samples"] for r in rows] == [256, 512, 768, 1024, 1280]
    assert rows[-1]["asi_version"] >= rows[2]["asi_version"]


def test_rsi_run_without_redis_and_refuses_to_overwrite(tmp_path, ray_local):
    out = tmp_path / "rsi"
    Trainer(small_config(out, init="rsi", samples=256), progress=False).run()
    rows = read_metrics(out)
    assert len(rows) == 1 and rows[0]["asi_version"] == 0
    from learner.errors import SfvError

    with pytest.raises(SfvError, match="--resume"):
        Trainer(small_config(out, init="rsi", samples=256), progress=False).run()


def test_cli_train_serial_and_eval(tmp_path):
    out = tmp_path / "cli"
    cmd = [sys.executable, "-m", "services.cli", "train", "--serial", "--workers", "1", "--envs-per-worker", "4",
           "--init", "fsi", "--samples", "128", "--batch-size", "128", "--out", str(out), "--quiet"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout.strip().splitlines()[-1])
    assert summary["samples"] == 128
    evaluated = subprocess.run([sys.executable, "-m", "services.cli", "eval", str(out), "--episodes", "2"],
                               capture_output=True, text=True, timeout=600)
    assert evaluated.returncode == 0, evaluated.stderr
    result = json.loads(evaluated.stdout)
    assert 0.0 <= result["normalized_return"] <= 1.0 and result["episodes"] == 2
    bad = subprocess.run([sys.executable, "-m", "services.cli", "eval", str(tmp_path / "nothing")], capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and bad.stderr.startswith("sfv: ") and "nothing" in bad.stderr
