"""bench/scripts/scaling.py's worker counts, and the real training loop over process workers (no Ray)."""
from __future__ import annotations

import pytest

from services.training.config import TrainConfig
from services.training.driver import Trainer
from services.training.run_dir import read_metrics
from tests.bench_scripts import load_bench_script


@pytest.fixture(scope="module")
def scaling():
    return load_bench_script("scaling")


@pytest.mark.parametrize("max_workers, counts", [(16, [1, 2, 4, 8, 16]), (12, [1, 2, 4, 8, 12]), (1, [1])])
def test_default_worker_counts_double_up_to_the_maximum(scaling, tmp_path, max_workers, counts):
    args = scaling.parse_args(["--max-workers", str(max_workers), "--out", str(tmp_path / "s.json")])
    assert args.counts == counts


def test_explicit_counts_and_bad_output(scaling, tmp_path):
    assert scaling.parse_args(["--workers", "4,1,4", "--out", str(tmp_path / "s.json")]).counts == [1, 4]
    with pytest.raises(SystemExit):
        scaling.parse_args(["--out", str(tmp_path / "no" / "s.json")])


@pytest.mark.integration
def test_training_runs_over_process_workers(tmp_path):
    config = TrainConfig(motion="deepmimic:walk", out=str(tmp_path / "run"), workers=2, envs_per_worker=2, init="asi",
                         samples=2 * 64, seed=1, asi_episodes_per_update=8, plot_every=0, runner="processes")
    config.ppo.batch_size, config.ppo.minibatch_size = 64, 32
    config.ppo.policy_hidden = config.ppo.value_hidden = (32, 32)
    import multiprocessing

    before = set(multiprocessing.active_children())
    trainer = Trainer(config, progress=False)
    try:
        record = trainer.run()
    finally:
        trainer.close()
    # the run stops its own workers when it ends (an asynchronous run's outlived it and held the cores)
    assert trainer.runner is None and set(multiprocessing.active_children()) <= before
    rows = read_metrics(tmp_path / "run")
    assert [r["samples"] for r in rows] == [64, 128]
    assert record["overall_samples_per_s"] > 0 and record["worker_failures"] == 0
