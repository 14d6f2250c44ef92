"""Checkpoints: exact resume, integrity checks, newest-complete lookup."""

import numpy as np
import pytest
import torch

from learner.checkpoint import checkpoint_path, latest_checkpoint, load_checkpoint, save_checkpoint
from learner.config import PPOConfig
from learner.errors import SfvError
from learner.ppo import PPOLearner
from tests.learner_helpers import behaviour_rollout

OBS_DIM, ACT_DIM = 6, 3


def config(seed=0):
    return PPOConfig(policy_hidden=(32, 16), value_hidden=(32, 16), minibatch_size=64, update_epochs=2, seed=seed)


def rollout(learner, seed, steps=8, envs=32):
    rng = np.random.default_rng(seed)
    batch = behaviour_rollout(learner, rng, steps, envs, OBS_DIM)
    obs, actions = batch["obs"], batch["actions"]
    return {
        **batch,
        "next_obs": np.roll(obs, -1, axis=0),
        "rewards": (1.0 - np.square(actions).mean(-1)).astype(np.float32),
        "terminated": rng.random((steps, envs)) < 0.05,
        "truncated": rng.random((steps, envs)) < 0.05,
    }


def flat_tensors(state, prefix=""):
    if isinstance(state, torch.Tensor):
        return {prefix: state}
    if isinstance(state, dict):
        out = {}
        for key, value in state.items():
            out.update(flat_tensors(value, f"{prefix}/{key}"))
        return out
    return {}


def test_round_trip_restores_bitwise_state_and_identical_next_update(tmp_path):
    original = PPOLearner(OBS_DIM, ACT_DIM, config())
    original.update(rollout(original, seed=1))
    path = checkpoint_path(tmp_path, 1)
    save_checkpoint(
        path,
        {
            "learner": original.state_dict(),
            "iteration": 1,
            "samples": 256,
            "asi_version": 7,
            "config": original.config.to_dict(),
            "episode_returns": np.array([1.5, 2.5], dtype=np.float32),
        },
    )
    payload = load_checkpoint(path)
    assert (payload["iteration"], payload["samples"], payload["asi_version"]) == (1, 256, 7)
    assert payload["config"]["policy_hidden"] == (32, 16)
    torch.testing.assert_close(payload["episode_returns"], torch.tensor([1.5, 2.5]))

    resumed = PPOLearner(OBS_DIM, ACT_DIM, PPOConfig.from_dict({**payload["config"], "seed": 99}))
    resumed.load_state_dict(payload["learner"])
    saved, restored = flat_tensors(original.state_dict()), flat_tensors(resumed.state_dict())
    assert saved.keys() == restored.keys()
    for key in saved:
        assert torch.equal(saved[key], restored[key]), key
    assert resumed.np_rng.bit_generator.state == original.np_rng.bit_generator.state

    batch = rollout(original, seed=2)
    assert original.update(batch) == resumed.update(batch)
    for (name, left), right in zip(original.policy_weights().items(), resumed.policy_weights().values()):
        assert np.array_equal(left, right), name


@pytest.fixture
def saved_checkpoint(tmp_path):
    learner = PPOLearner(OBS_DIM, ACT_DIM, config())
    path = save_checkpoint(checkpoint_path(tmp_path, 3), {"learner": learner.state_dict(), "iteration": 3})
    return path


def test_truncated_file_is_reported(saved_checkpoint):
    data = saved_checkpoint.read_bytes()
    saved_checkpoint.write_bytes(data[: len(data) // 2])
    with pytest.raises(SfvError, match="checkpoint is truncated or corrupt") as error:
        load_checkpoint(saved_checkpoint)
    assert str(saved_checkpoint) in str(error.value)
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("fraction", [0.1, 0.5, 0.9])
def test_flipped_byte_in_tensor_data_is_reported(saved_checkpoint, fraction):
    data = bytearray(saved_checkpoint.read_bytes())
    # torch stores tensor bytes uncompressed, so the policy's first weight matrix is findable.
    weight = load_checkpoint(saved_checkpoint)["learner"]["policy"]["mean_net.0.weight"].numpy().tobytes()
    start = data.find(weight[:64])
    assert start > 0
    data[start + int(fraction * len(weight))] ^= 0x40
    saved_checkpoint.write_bytes(bytes(data))
    with pytest.raises(SfvError, match=r"truncated or corrupt \(SHA-256"):
        load_checkpoint(saved_checkpoint)


def test_missing_and_foreign_files_are_reported(tmp_path):
    with pytest.raises(SfvError, match="checkpoint not found"):
        load_checkpoint(tmp_path / "nope.pt")
    foreign = tmp_path / "foreign.pt"
    torch.save({"weights": torch.zeros(3)}, foreign)
    with pytest.raises(SfvError, match="not an sfv checkpoint"):
        load_checkpoint(foreign)


def test_latest_checkpoint_skips_temp_and_damaged_files(tmp_path):
    assert latest_checkpoint(tmp_path) is None
    for iteration in (1, 2, 10):
        save_checkpoint(checkpoint_path(tmp_path, iteration), {"iteration": iteration})
    (tmp_path / ".checkpoint_000000011.pt.abc123.tmp").write_bytes(b"partial")
    damaged = checkpoint_path(tmp_path, 12)
    save_checkpoint(damaged, {"iteration": 12})
    damaged.write_bytes(damaged.read_bytes()[:100])
    newest = latest_checkpoint(tmp_path)
    assert newest == checkpoint_path(tmp_path, 10)
    assert load_checkpoint(newest)["iteration"] == 10


def test_save_leaves_no_temp_file_and_replaces_atomically(tmp_path):
    path = tmp_path / "run" / "checkpoint_000000001.pt"
    save_checkpoint(path, {"iteration": 1})
    save_checkpoint(path, {"iteration": 2})
    assert [entry.name for entry in path.parent.iterdir()] == [path.name]
    assert load_checkpoint(path)["iteration"] == 2
    with pytest.raises(TypeError, match="cannot store a set"):
        save_checkpoint(path, {"bad": {1, 2}})
    assert load_checkpoint(path)["iteration"] == 2
    assert [entry.name for entry in path.parent.iterdir()] == [path.name]


def test_a_learner_starts_from_another_s_weights_dropping_the_wrench_actions():
    """The body-alone stage's start: the helped learner has a residual wrench's six more action numbers."""
    helped = PPOLearner(OBS_DIM, ACT_DIM + 6, config(seed=1))
    helped.update(rollout(helped, 1))  # trained a little: its normaliser and weights are not the initial ones
    alone = PPOLearner(OBS_DIM, ACT_DIM, config(seed=2))
    assert alone.start_from(helped.state_dict()) == 6
    obs = torch.as_tensor(np.random.default_rng(3).normal(size=(5, OBS_DIM)), dtype=torch.float32)
    with torch.no_grad():
        torch.testing.assert_close(alone.policy(alone.normalizer(obs)), helped.policy(helped.normalizer(obs))[:, :ACT_DIM])
        torch.testing.assert_close(alone.value(alone.normalizer(obs)), helped.value(helped.normalizer(obs)))
    # The optimiser starts afresh; a learner for another observation, or one with fewer actions, cannot start it.
    assert not alone.policy_optimizer.state
    with pytest.raises(SfvError, match="obs_dim/act_dim"):
        alone.start_from(PPOLearner(OBS_DIM + 1, ACT_DIM + 6, config()).state_dict())
    with pytest.raises(SfvError, match="actions may only be dropped"):
        PPOLearner(OBS_DIM, ACT_DIM + 7, config()).start_from(helped.state_dict())
    with pytest.raises(SfvError, match="do not fit"):
        PPOLearner(OBS_DIM, ACT_DIM, PPOConfig(policy_hidden=(8,), value_hidden=(8,))).start_from(helped.state_dict())
