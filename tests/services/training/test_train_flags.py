"""`sfv train` flags that reach the PPO and learner settings, and their validation."""
from __future__ import annotations

import argparse
import os

import pytest

from learner.errors import SfvError
from services.commands import train
from services.training.driver import _set_torch_threads


def parse(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    train.register(parser.add_subparsers())
    return parser.parse_args(["train", *argv])


def test_epochs_learning_rate_and_threads_reach_the_config(tmp_path):
    config = train.build_config(parse("--out", str(tmp_path / "run"), "--epochs", "3", "--policy-lr", "1e-4", "--torch-threads", "1"))
    config.validate()
    assert (config.ppo.update_epochs, config.ppo.policy_lr, config.torch_threads) == (3, 1e-4, 1)
    assert _set_torch_threads(config) == 1


def test_defaults_are_one_pass_synchronous_and_every_core(tmp_path):
    config = train.build_config(parse("--out", str(tmp_path / "run")))
    assert config.ppo.update_epochs == 1  # DeepMimic's single pass over each batch
    assert config.policy_lag == 0  # the synchronous loop (docs/scaling.md: the jump learns less per sample asynchronously)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert _set_torch_threads(config) == cores


def test_the_asynchronous_loop_gives_the_learner_the_cores_the_workers_leave_but_not_in_process(tmp_path):
    config = train.build_config(parse("--out", str(tmp_path / "run"), "--max-policy-lag", "1"))
    assert config.policy_lag == 1
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert _set_torch_threads(config) == max(1, cores - config.workers)
    in_process = train.build_config(parse("--out", str(tmp_path / "run2"), "--max-policy-lag", "1", "--runner", "in_process"))
    assert in_process.policy_lag == 0 and _set_torch_threads(in_process) == cores


def test_sample_counts_take_the_benchmarks_suffixes(tmp_path):
    config = train.build_config(parse("--out", str(tmp_path / "run"), "--samples", "3M", "--eval-every", "250k", "--curriculum-samples", "1e6"))
    assert (config.samples, config.eval_every, config.curriculum_samples) == (3_000_000, 250_000, 1_000_000)


@pytest.mark.parametrize("flag, value", [("--epochs", "0"), ("--torch-threads", "-1"), ("--policy-lr", "-1e-5"), ("--epochs", "two"),
                                         ("--samples", "1.5"), ("--samples", "3X")])
def test_bad_flag_values_exit_2_naming_the_flag(tmp_path, capsys, flag, value):
    with pytest.raises(SystemExit) as exit_info:
        parse("--out", str(tmp_path / "run"), f"{flag}={value}")
    assert exit_info.value.code == 2
    assert flag in capsys.readouterr().err


def test_ppo_settings_changed_in_place_are_validated_before_training(tmp_path):
    config = train.build_config(parse("--out", str(tmp_path / "run")))
    config.ppo.update_epochs = 0
    with pytest.raises(SfvError, match="update_epochs"):
        config.validate()


def test_a_device_this_node_lacks_is_a_one_line_error_before_training(tmp_path, capsys):
    import torch

    from services.cli import main
    from services.training.driver import check_learner_device

    assert check_learner_device("cpu") == "cpu"
    assert check_learner_device("auto") == ("cuda" if torch.cuda.is_available() else "cpu")  # the default
    with pytest.raises(SfvError, match=r"^--device gpu0: not a torch device"):
        check_learner_device("gpu0")
    if torch.cuda.is_available():
        pytest.skip("this node has CUDA: the missing-GPU message cannot show")
    pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")
    run = tmp_path / "run"
    code = main(["train", "--out", str(run), "--device", "cuda", "--runner", "in_process", "--workers", "1", "--envs-per-worker", "2",
                 "--samples", "64", "--batch-size", "64", "--eval-every", "0", "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and err[-1].startswith("sfv: --device cuda: torch ") and "--device cpu" in err[-1]
    assert not list(run.glob("checkpoint_*.pt"))
