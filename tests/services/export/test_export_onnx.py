"""`sfv export RUN --onnx`: the checkpoint's policy as ONNX, and the torch-free ONNX paths.

`make_tiny_run` (also used by the render, rollout-export and plot tests) writes a real run
directory by hand: config.json, one checkpoint saved by `learner.checkpoint` from a real
(small) PPOLearner whose observation normaliser has seen shifted, scaled data, and a few
metrics rows. No training, so the tests stay fast.
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from actors.character.features import observation_dim
from actors.envs.imitation_env import EnvConfig
from learner.checkpoint import checkpoint_path, save_checkpoint
from learner.onnx_export import OnnxPolicy
from learner.ppo import PPOLearner
from services.cli import main
from services.training.config import TrainConfig
from services.training.run_dir import CONFIG_FILE, METRICS_FILE

OBS_DIM = observation_dim(len(EnvConfig().reference_obs_steps))  # the default env's observation

REPO = Path(__file__).resolve().parents[3]
ACT_DIM = 28  # the default exp-map (residual) actions: 8 ball joints x 3 + 4 hinges


def make_tiny_run(run_dir: Path, init: str = "rsi", seed: int = 0, hidden=(64,), returns=(0.05, 0.1, 0.2),
                  env: EnvConfig = EnvConfig()) -> PPOLearner:
    """`env`: the run's env settings (its character sizes the observation and the actions)."""
    from actors.character.characters import character_named

    run_dir.mkdir(parents=True, exist_ok=True)
    config = TrainConfig(motion="deepmimic:walk", out=str(run_dir), init=init, seed=seed, runner="in_process", env=env)
    config.ppo.policy_hidden = tuple(hidden)
    config.ppo.value_hidden = (16,)
    config.ppo.seed = seed
    (run_dir / CONFIG_FILE).write_text(json.dumps(config.to_dict()))
    character = character_named(env.character)
    obs_dim = observation_dim(len(env.reference_obs_steps), character)
    wrench = 6 if env.residual_force > 0 else 0  # a residual root wrench's six outputs after the joints'
    learner = PPOLearner(obs_dim, character.nu + wrench, config.ppo)  # exp-map actions: one per actuator
    rng = np.random.default_rng(seed)
    learner.normalizer.update(torch.as_tensor(rng.normal(0.5, 3.0, size=(256, obs_dim)), dtype=torch.float32))
    with torch.no_grad():  # a visibly non-zero policy, so that exports and rollouts are not trivial
        learner.policy.mean_net[-1].weight.mul_(30.0)
    payload = {"learner": learner.state_dict(), "policy_weights": learner.policy_weights(), "samples": 4096,
               "iteration": 4, "asi_version": 0, "worker_failures": 0, "config": config.to_dict()}
    save_checkpoint(checkpoint_path(run_dir, 4), payload)
    with open(run_dir / METRICS_FILE, "w") as f:
        for k, value in enumerate(returns, 1):
            f.write(json.dumps({"iteration": k, "samples": 1024 * k, "normalized_return": value}) + "\n")
    return learner


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("run") / "walk_rsi"
    learner = make_tiny_run(run_dir)
    return run_dir, learner


@pytest.fixture(scope="module")
def exported(tiny_run, tmp_path_factory):
    run_dir, _ = tiny_run
    out = tmp_path_factory.mktemp("onnx") / "policy.onnx"
    assert main(["export", str(run_dir), "--onnx", str(out)]) == 0
    return out


def test_onnx_matches_the_torch_policy_and_numpy_policy(tiny_run, exported):
    from learner.policy import NumpyPolicy
    from services.training.run_dir import load_run

    _, learner = tiny_run
    rng = np.random.default_rng(7)
    obs = rng.normal(0.5, 6.0, size=(50, OBS_DIM)).astype(np.float32)
    obs[0, :4] = [400.0, -400.0, 0.0, 90.0]  # far beyond the normaliser's clip
    with torch.no_grad():
        torch_mean = learner.policy(learner.normalizer(torch.from_numpy(obs))).numpy()
    onnx_actions, _ = OnnxPolicy(exported).act(obs, deterministic=True)
    _, weights = load_run(tiny_run[0])
    numpy_actions, _ = NumpyPolicy(weights, max_batch=50).act(obs, deterministic=True)
    assert np.abs(torch_mean).max() > 0.5  # the comparison is not between near-zero outputs
    np.testing.assert_allclose(onnx_actions, torch_mean, atol=1e-5, rtol=0)
    np.testing.assert_allclose(onnx_actions, numpy_actions, atol=1e-5, rtol=0)


def test_export_prints_its_check_and_leaves_no_temp_file(tiny_run, tmp_path, capsys):
    out = tmp_path / "p.onnx"
    assert main(["export", str(tiny_run[0]), "--onnx", str(out)]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["onnx"] == str(out) and report["obs_dim"] == OBS_DIM and report["act_dim"] == ACT_DIM
    assert report["max_abs_diff_vs_checkpoint"] < 1e-5
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.onnx"]


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--onnx", "{tmp}/p.txt"], "must end in .onnx"),
        (["--onnx", "{tmp}/missing_dir/p.onnx"], "does not exist"),
        ([], "give --onnx FILE"),
    ],
)
def test_bad_export_arguments_are_one_line_errors(tiny_run, tmp_path, capsys, argv, message):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert main(["export", str(tiny_run[0]), *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("sfv: ") and message in err and "\n" not in err
    assert list(tmp_path.iterdir()) == []


def test_export_from_a_folder_without_checkpoint_fails_cleanly(tmp_path, capsys):
    (tmp_path / CONFIG_FILE).write_text(json.dumps(TrainConfig().to_dict()))
    assert main(["export", str(tmp_path), "--onnx", str(tmp_path / "p.onnx")]) == 2
    assert "no checkpoint" in capsys.readouterr().err
    assert not (tmp_path / "p.onnx").exists()


# ------------------------------------------------------------- torch-free paths
NO_TORCH = """
import json, sys
from services.cli import main
code = main(sys.argv[1:])
print(json.dumps({"code": code, "torch": "torch" in sys.modules}))
"""


def _run_without_torch(*argv: str) -> dict:
    result = subprocess.run([sys.executable, "-c", NO_TORCH, *argv], capture_output=True, text=True, timeout=120, cwd=REPO)
    assert result.returncode == 0, result.stderr[-2000:]
    return json.loads(result.stdout.strip().splitlines()[-1])


def test_eval_of_an_onnx_policy_does_not_import_torch(tiny_run, exported):
    outcome = _run_without_torch("eval", str(tiny_run[0]), "--onnx", str(exported), "--episodes", "1")
    assert outcome == {"code": 0, "torch": False}


def test_render_of_an_onnx_policy_does_not_import_torch(exported, tmp_path):
    video = tmp_path / "onnx.mp4"
    outcome = _run_without_torch("render", "--onnx", str(exported), "--motion", "deepmimic:walk", "--out", str(video),
                                 "--seconds", "0.2", "--width", "96", "--height", "72")
    assert outcome == {"code": 0, "torch": False}
    assert video.stat().st_size > 0
