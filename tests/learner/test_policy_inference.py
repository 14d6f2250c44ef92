"""learner.policy.NumpyPolicy against the learner's torch networks."""

import numpy as np
import pytest
import torch
from torch.distributions import Normal

from learner.config import PPOConfig
from learner.errors import SfvError
from learner.policy import NumpyPolicy
from learner.ppo import PPOLearner

OBS_DIM, ACT_DIM = 197, 36


@pytest.fixture(scope="module")
def learner():
    """Paper-sized nets with a non-trivial normaliser and a policy head large enough that
    the means are O(1) (the fresh head's 0.01 gain would make any comparison trivial)."""
    learner = PPOLearner(OBS_DIM, ACT_DIM, PPOConfig(seed=3))
    rng = np.random.default_rng(0)
    learner.normalizer.update(torch.as_tensor(rng.normal(2.0, 3.0, size=(500, OBS_DIM)), dtype=torch.float32))
    with torch.no_grad():
        learner.policy.mean_net[-1].weight.mul_(100.0)
        learner.policy.mean_net[-1].bias.uniform_(-0.5, 0.5)
    return learner


def random_obs(rows, seed):
    rng = np.random.default_rng(seed)
    obs = rng.normal(2.0, 3.0, size=(rows, OBS_DIM)).astype(np.float32)
    obs[0, :5] = [1e3, -1e3, 50.0, -50.0, 2.0]  # exercise the obs clip
    return obs


def torch_mean(learner, obs):
    with torch.no_grad():
        return learner.policy(learner.normalizer(torch.from_numpy(obs))).numpy()


def test_mean_matches_torch(learner):
    policy = NumpyPolicy(learner.policy_weights(), max_batch=16)
    obs = random_obs(16, seed=1)
    expected = torch_mean(learner, obs)
    assert np.abs(expected).max() > 0.5
    np.testing.assert_allclose(policy.mean(obs), expected, atol=1e-5, rtol=0)
    actions, logp = policy.act(obs, deterministic=True)
    np.testing.assert_allclose(actions, expected, atol=1e-5, rtol=0)


def test_sampled_logp_matches_torch_normal(learner):
    policy = NumpyPolicy(learner.policy_weights(), max_batch=32)
    obs = random_obs(32, seed=2)
    actions, logp = policy.act(obs, np.random.default_rng(5))
    assert actions.dtype == np.float32 and logp.dtype == np.float32
    with torch.no_grad():
        normal = Normal(torch.from_numpy(torch_mean(learner, obs)), learner.policy.log_std.exp())
        expected = normal.log_prob(torch.from_numpy(actions)).sum(-1).numpy()
        learner_logp = learner.policy.log_prob(learner.normalizer(torch.from_numpy(obs)), torch.from_numpy(actions))
    np.testing.assert_allclose(logp, expected, rtol=1e-5, atol=1e-4)
    np.testing.assert_allclose(logp, learner_logp.numpy(), rtol=1e-5, atol=1e-4)


def test_samples_follow_the_gaussian(learner):
    policy = NumpyPolicy(learner.policy_weights(), max_batch=8)
    obs = np.repeat(random_obs(1, seed=3), 20000, axis=0)
    actions, _ = policy.act(obs, np.random.default_rng(6))  # grows the buffers past max_batch
    std = learner.config.action_std
    np.testing.assert_allclose(actions.mean(0), torch_mean(learner, obs[:1])[0], atol=5 * std / np.sqrt(20000))
    np.testing.assert_allclose(actions.std(0), std, rtol=0.05)
    # Unclipped: the env, not the policy, clips to [-1, 1].
    assert np.abs(actions).max() > 1.0


def test_out_buffers_are_written_in_place(learner):
    policy = NumpyPolicy(learner.policy_weights(), max_batch=4)
    obs = random_obs(4, seed=4)
    trajectory_actions = np.zeros((3, 4, ACT_DIM), np.float32)
    trajectory_logp = np.zeros((3, 4), np.float32)
    actions, logp = policy.act(obs, np.random.default_rng(7), out_actions=trajectory_actions[1], out_logp=trajectory_logp[1])
    assert np.shares_memory(actions, trajectory_actions) and np.shares_memory(logp, trajectory_logp)
    fresh_actions, fresh_logp = policy.act(obs, np.random.default_rng(7))
    np.testing.assert_array_equal(trajectory_actions[1], fresh_actions)
    np.testing.assert_array_equal(trajectory_logp[1], fresh_logp)
    assert not trajectory_actions[0].any() and not trajectory_actions[2].any()


def test_load_weights_updates_in_place_and_rejects_mismatches(learner):
    old_weights = learner.policy_weights()
    policy = NumpyPolicy(old_weights, max_batch=4)
    obs = random_obs(4, seed=5)
    new_weights = {key: value.copy() for key, value in old_weights.items()}
    new_weights["layer2.bias"] += 0.25
    policy.load_weights(new_weights)
    np.testing.assert_allclose(policy.mean(obs), NumpyPolicy(new_weights).mean(obs), atol=0, rtol=0)
    np.testing.assert_allclose(policy.mean(obs), torch_mean(learner, obs) + 0.25, atol=1e-5)

    wrong = dict(new_weights, **{"layer1.weight": np.zeros((1024, 7), np.float32)})
    with pytest.raises(SfvError, match="layer1"):
        policy.load_weights(wrong)
    with pytest.raises(SfvError, match="action_std must be positive"):
        policy.load_weights(dict(new_weights, action_std=np.zeros(ACT_DIM, np.float32)))
    with pytest.raises(SfvError, match="layer0.weight contains NaN"):
        policy.load_weights(dict(new_weights, **{"layer0.weight": np.full((OBS_DIM, 1024), np.nan, np.float32)}))
    # A rejected dict leaves the previous weights in force.
    np.testing.assert_allclose(policy.mean(obs), NumpyPolicy(new_weights).mean(obs), atol=0, rtol=0)


def test_bad_obs_shape_and_missing_rng_are_refused(learner):
    policy = NumpyPolicy(learner.policy_weights())
    with pytest.raises(ValueError, match=r"obs must be \(M, 197\)"):
        policy.act(np.zeros((2, 10), np.float32), np.random.default_rng())
    with pytest.raises(ValueError, match="Generator is required"):
        policy.act(np.zeros((2, OBS_DIM), np.float32))
