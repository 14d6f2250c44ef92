"""The motor module that ships in the repository (`--module pretrained`, learner/pretrained/motor_module)."""
import json
import tomllib

import numpy as np
import pytest

from learner.errors import SfvError
from learner.motor_decoder import PRETRAINED_DIR, LatentDecoder, module_path
from tests.conftest import REPO

SHIPPED = ("config.json", "decoder.npz", "decoder.onnx", "PROVENANCE.md")


def test_the_module_ships_in_the_package_with_its_provenance():
    for name in SHIPPED:
        assert (PRETRAINED_DIR / name).is_file(), name
    package_data = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["learner"]
    assert "pretrained/motor_module/*" in package_data
    record = json.loads((PRETRAINED_DIR / "config.json").read_text())
    assert record["clips"] and set(record["held_out"]).isdisjoint(record["clips"])
    assert record["latent_range"]["abs_p95"] > 0
    provenance = (PRETRAINED_DIR / "PROVENANCE.md").read_text()
    assert "sfv distill" in provenance and "sfv experts" in provenance
    assert sum(path.stat().st_size for path in PRETRAINED_DIR.iterdir()) < 8 * 2**20  # a few MB, not a run directory


def test_numpy_and_onnx_decoders_of_the_shipped_module_agree():
    ort = pytest.importorskip("onnxruntime")  # noqa: F841
    from learner.motor_decoder_onnx import OnnxLatentDecoder

    decoder = LatentDecoder.load("pretrained")
    rng = np.random.default_rng(0)
    proprio = rng.standard_normal((4, decoder.proprio_dim)).astype(np.float32)
    z = rng.standard_normal((4, decoder.latent_dim)).astype(np.float32)
    targets = decoder(proprio, z)
    assert targets.shape == (4, 28) and np.isfinite(targets).all()
    np.testing.assert_allclose(OnnxLatentDecoder(PRETRAINED_DIR / "decoder.onnx")(proprio, z), targets, atol=1e-4)


def test_the_shipped_decoder_keeps_the_walker_up_at_the_prior_mean():
    """z = 0 throughout (the chance line of the task table): the walker must not fall within 3 s
    from walk and run starts. A broken or mis-ordered decoder drops it within about a second."""
    from actors.envs.tasks.config import TaskEnvConfig
    from actors.envs.tasks.vector_task_env import VectorTaskEnv

    env = VectorTaskEnv(TaskEnvConfig(task="go_to", action="latent", horizon_s=3.0), 4, seed=0)
    env.reset()
    env.episodes.drain()
    actions = np.zeros((4, env.action_dim), np.float32)
    for _ in range(env.max_episode_steps):
        env.step(actions)
    log = env.episodes.drain()
    assert len(log["fell"]) == 4 and not log["fell"].any()


def test_a_missing_shipped_module_is_one_clear_error(monkeypatch, tmp_path):
    import learner.motor_decoder as motor_decoder

    monkeypatch.setattr(motor_decoder, "PRETRAINED_DIR", tmp_path / "absent")
    with pytest.raises(SfvError, match="--module pretrained: the shipped module is missing"):
        module_path("pretrained")
    assert module_path(tmp_path) == tmp_path


def test_the_npmp_pretrained_spec_describes_the_shipped_module():
    from services.specs import specs_for

    spec = specs_for("distill")["npmp-pretrained"].settings
    record = json.loads((PRETRAINED_DIR / "config.json").read_text())
    assert record["module"]["beta"] == spec["beta"]
    assert sorted(record["clips"]) == sorted(set(spec["clips"]) - set(spec["hold_out"]))
    assert record["held_out"] == list(spec["hold_out"])


def test_principal_latent_actions_move_z_around_the_posterior_centre():
    from actors.envs.tasks.action_spaces import LatentActions

    full = LatentActions("pretrained", latent_scale=1.5)
    eight = LatentActions("pretrained", latent_scale=1.5, directions=8)
    assert (full.action_dim, eight.action_dim) == (60, 8)
    record = json.loads((PRETRAINED_DIR / "config.json").read_text())["latent_range"]["principal"]
    np.testing.assert_allclose(eight.latents(np.zeros((1, 8))), [record["mean"]], atol=1e-9)
    step = eight.latents(np.eye(8)[:1]) - eight.latents(np.zeros((1, 8)))  # +1 on the first direction
    assert np.linalg.norm(step) == pytest.approx(1.5 * record["std"][0], rel=1e-4)
    assert record["cumulative_variance"][7] > 0.8  # 8 directions hold most of where the experts' z lie
    assert LatentActions("pretrained", directions=40).action_dim == 16  # as many as the module records
