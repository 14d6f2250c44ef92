"""Issue 16's integration check: two tiny experts, distilled into a tiny motor module, then a
task-policy iteration on its frozen decoder (and its evaluation).

Runs where the motor-module code (`learner/motor_decoder.py`, `services/motor/`, `sfv distill`)
is present; skips cleanly otherwise.
"""
import json

import numpy as np
import pytest

pytest.importorskip("pybullet_data", reason="the experts imitate DeepMimic clips")
pytest.importorskip("learner.motor_decoder", reason="needs the motor module (issue 16 item 3)")
pytest.importorskip("services.motor.training", reason="needs the motor module (issue 16 item 3)")


def train_tiny_expert(clip: str, out):
    from learner.config import PPOConfig
    from services.training.config import TrainConfig
    from services.training.driver import Trainer

    ppo = PPOConfig(batch_size=256, minibatch_size=128, policy_hidden=(16,), value_hidden=(16,))
    config = TrainConfig(motion=f"deepmimic:{clip}", out=str(out), workers=1, envs_per_worker=4, init="rsi", samples=512,
                         runner="in_process", torch_threads=1, eval_every=0, plot_every=0, curriculum_start_s=0.0, ppo=ppo)
    with Trainer(config, progress=False) as trainer:
        trainer.run()


@pytest.mark.slow
def test_two_tiny_experts_distilled_then_one_task_iteration(tmp_path, capsys):
    from services.cli import main

    experts, module, run = tmp_path / "experts", tmp_path / "module", tmp_path / "go_to"
    for clip in ("walk", "run"):
        train_tiny_expert(clip, experts / clip)
    assert main(["distill", str(experts), "--out", str(module), "--clips", "walk", "run", "--steps-per-clip", "120",
                 "--episode-steps", "30", "--updates", "4", "--latent-dim", "4", "--encoder-hidden", "16",
                 "--decoder-hidden", "16", "--window", "4", "--batch-windows", "4", "--quiet", "--device", "cpu"]) == 0
    assert main(["task", "go-to", "--module", str(module), "--out", str(run), "--samples", "64", "--runner", "in_process",
                 "--workers", "1", "--envs-per-worker", "2", "--torch-threads", "1", "--horizon-s", "1", "--batch-size", "64", "--quiet"]) == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["samples"] >= 64 and summary["iteration"] == 1
    rows = [json.loads(line) for line in (run / "metrics.jsonl").read_text().splitlines()]
    assert len(rows) == 1 and np.isfinite(rows[0]["losses/policy_loss"])
    config = json.loads((run / "config.json").read_text())
    assert config["env"]["action"] == "latent" and config["env"]["module"] == str(module)
    assert len(json.loads((module / "config.json").read_text())["latent_range"]["principal"]["directions"]) == 4  # min(16, latent 4)
    assert main(["task", "eval", str(run), "--episodes", "2"]) == 0
    figures = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert 0.0 <= figures["success_rate"] <= 1.0 and figures["pose_log_density"] is not None
    lines = figures["motion_distance_lines"]
    assert lines["standing_still"] < lines["mocap_held_out"] and "motion_distance" in figures


def test_latent_actions_drive_the_character_with_the_decoder(tmp_path):
    """The latent env's targets are the decoder's, clipped to the joint limits, batched over envs."""
    from actors.character.actions import ActionMapper
    from actors.envs.tasks.config import TaskEnvConfig
    from actors.envs.tasks.vector_task_env import VectorTaskEnv
    from learner.motor_decoder import LatentDecoder, save_decoder_npz

    rng = np.random.default_rng(0)
    weights = {"proprio_mean": np.zeros(196, np.float32), "proprio_std": np.ones(196, np.float32),
               "input_clip": np.float32(10.0), "latent_dim": np.int64(3), "action_std": np.full(28, 0.1, np.float32),
               "layer0.weight": rng.normal(0, 0.05, (199, 8)).astype(np.float32), "layer0.bias": np.zeros(8, np.float32),
               "layer1.weight": rng.normal(0, 0.5, (8, 28)).astype(np.float32), "layer1.bias": np.zeros(28, np.float32)}
    save_decoder_npz(weights, tmp_path / "decoder.npz")
    (tmp_path / "config.json").write_text(json.dumps({"latent_dim": 3}))
    env = VectorTaskEnv(TaskEnvConfig(action="latent", module=str(tmp_path), latent_scale=2.0, latent_directions=0), 3, seed=0)
    assert env.action_dim == 3
    obs = env.reset()
    actions = rng.uniform(-1.5, 1.5, (3, 3)).astype(np.float32)
    expected = LatentDecoder.load(tmp_path)(obs[:, :196], 2.0 * np.clip(actions, -1, 1))
    limits = ActionMapper("exp_map", None)
    env.step(actions)
    np.testing.assert_allclose(np.stack([d.ctrl for d in env.datas]), np.clip(expected, limits.lower, limits.upper), rtol=1e-5, atol=1e-6)
