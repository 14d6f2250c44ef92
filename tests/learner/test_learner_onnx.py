"""ONNX export of the policy mean, checked against the torch networks with onnxruntime."""

import subprocess
import sys

import numpy as np
import onnx
import pytest
import torch

from learner.config import PPOConfig
from learner.errors import SfvError
from learner.onnx_export import OnnxPolicy, export_policy_onnx
from learner.ppo import PPOLearner

OBS_DIM, ACT_DIM = 197, 36


@pytest.fixture(scope="module")
def learner():
    learner = PPOLearner(OBS_DIM, ACT_DIM, PPOConfig(seed=4))
    rng = np.random.default_rng(1)
    learner.normalizer.update(torch.as_tensor(rng.normal(-1.0, 4.0, size=(300, OBS_DIM)), dtype=torch.float32))
    with torch.no_grad():
        learner.policy.mean_net[-1].weight.mul_(100.0)
    return learner


@pytest.fixture(scope="module")
def exported(learner, tmp_path_factory):
    return export_policy_onnx(learner.policy_weights(), tmp_path_factory.mktemp("onnx") / "policy.onnx")


@pytest.mark.parametrize("rows", [1, 37])
def test_onnx_mean_matches_torch(learner, exported, rows):
    rng = np.random.default_rng(rows)
    obs = rng.normal(-1.0, 4.0, size=(rows, OBS_DIM)).astype(np.float32)
    obs[0, :3] = [500.0, -500.0, 30.0]  # beyond the obs clip
    with torch.no_grad():
        expected = learner.policy(learner.normalizer(torch.from_numpy(obs))).numpy()
    actions, logp = OnnxPolicy(exported).act(obs, deterministic=True)
    assert actions.shape == (rows, ACT_DIM) and np.abs(expected).max() > 0.5
    np.testing.assert_allclose(actions, expected, atol=1e-5, rtol=0)
    with torch.no_grad():
        expected_logp = learner.policy.log_prob(learner.normalizer(torch.from_numpy(obs)), torch.from_numpy(actions))
    np.testing.assert_allclose(logp, expected_logp.numpy(), rtol=1e-5, atol=1e-4)


def test_graph_has_named_io_and_dynamic_batch(exported):
    model = onnx.load(exported)
    (graph_input,), (graph_output,) = model.graph.input, model.graph.output
    assert graph_input.name == "obs" and graph_output.name == "action_mean"
    input_dims = graph_input.type.tensor_type.shape.dim
    assert input_dims[0].dim_param == "batch" and input_dims[1].dim_value == OBS_DIM
    assert graph_output.type.tensor_type.shape.dim[1].dim_value == ACT_DIM
    assert [entry.name for entry in exported.parent.iterdir()] == [exported.name]  # no temp file left


def test_stochastic_act_uses_the_exported_std(learner, exported):
    obs = np.zeros((5000, OBS_DIM), np.float32)
    mean, _ = OnnxPolicy(exported).act(obs[:1])
    actions, _ = OnnxPolicy(exported).act(obs, np.random.default_rng(0), deterministic=False)
    np.testing.assert_allclose(actions.std(0), learner.config.action_std, rtol=0.08)
    np.testing.assert_allclose(actions.mean(0), mean[0], atol=5 * learner.config.action_std / np.sqrt(5000))


def test_onnx_policy_runs_without_torch(exported):
    script = (
        "import sys, numpy as np; from learner.onnx_export import OnnxPolicy;"
        f"a, _ = OnnxPolicy(sys.argv[1]).act(np.zeros((2, {OBS_DIM}), np.float32));"
        "assert a.shape == (2, 36) and 'torch' not in sys.modules; print('ok')"
    )
    result = subprocess.run([sys.executable, "-c", script, str(exported)], capture_output=True, text=True, timeout=60)
    assert result.returncode == 0 and result.stdout.strip() == "ok", result.stderr


def test_broken_file_is_reported(tmp_path):
    broken = tmp_path / "broken.onnx"
    broken.write_bytes(b"not an onnx model")
    with pytest.raises(SfvError, match="not a valid sfv ONNX policy"):
        OnnxPolicy(broken)
    with pytest.raises(SfvError, match="ONNX policy not found"):
        OnnxPolicy(tmp_path / "missing.onnx")
