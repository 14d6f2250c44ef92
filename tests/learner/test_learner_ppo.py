"""PPO update: clipped objective, learning on a bandit, and refusal of non-finite data."""

import numpy as np
import pytest
import torch

from learner.config import PPOConfig
from learner.errors import BatchFormatError, NonFiniteError, SfvError
from learner.policy import NumpyPolicy
from learner.ppo import PPOLearner, clipped_surrogate_loss

CLEANRL_METRICS = (
    "losses/policy_loss",
    "losses/value_loss",
    "losses/entropy",
    "losses/approx_kl",
    "losses/clipfrac",
    "losses/explained_variance",
)


def test_clipped_objective_value_and_zero_gradient_where_clipped():
    ratios = torch.tensor([0.5, 0.9, 1.1, 1.5, 0.5, 1.5], dtype=torch.float64)
    advantages = torch.tensor([1.0, 1.0, -1.0, 1.0, -1.0, -1.0], dtype=torch.float64)
    old_logp = torch.zeros(6, dtype=torch.float64)
    new_logp = ratios.log().requires_grad_()
    loss, ratio, _ = clipped_surrogate_loss(new_logp, old_logp, advantages, clip_coef=0.2)
    loss.backward()
    # Per-sample max(-A r, -A clip(r)):  -0.5, -0.9, 1.1, -1.2 (clipped), 0.8 (clipped), 1.5
    assert loss.item() == pytest.approx((-0.5 - 0.9 + 1.1 - 1.2 + 0.8 + 1.5) / 6)
    torch.testing.assert_close(ratio.detach(), ratios)
    # d/dlogp of -A r is -A r; clipped samples (r > 1.2 with A > 0, r < 0.8 with A < 0) get 0.
    expected_grad = torch.tensor([-0.5, -0.9, 1.1, 0.0, 0.0, 1.5], dtype=torch.float64) / 6
    torch.testing.assert_close(new_logp.grad, expected_grad)


def small_config(**overrides):
    values = dict(
        policy_hidden=(32, 32),
        value_hidden=(32, 32),
        minibatch_size=64,
        update_epochs=4,
        action_std=0.2,
        policy_lr=3e-3,
        value_lr=3e-3,
        target_kl=None,
        seed=0,
        # The bandit's rewards are negative (and one test overflows them on purpose): no
        # clipping of value targets to the imitation reward's [0, 1 / (1 - gamma)]
        # (tests/learner/test_learner_value_clip.py covers that).
        reward_max=None,
    )
    values.update(overrides)
    return PPOConfig(**values)


TARGET = np.array([0.5, -0.3], dtype=np.float32)


def bandit_batch(policy, rng, steps=8, envs=64, obs_dim=3):
    """One-step episodes whose reward is -|a - TARGET|^2 for the env-clipped action."""
    obs = rng.normal(size=(steps, envs, obs_dim)).astype(np.float32)
    actions = np.empty((steps, envs, 2), np.float32)
    logp = np.empty((steps, envs), np.float32)
    for t in range(steps):
        policy.act(obs[t], rng, out_actions=actions[t], out_logp=logp[t])
    rewards = -np.square(np.clip(actions, -1.0, 1.0) - TARGET).sum(-1)
    return {
        "obs": obs,
        "next_obs": rng.normal(size=obs.shape).astype(np.float32),
        "actions": actions,
        "logp": logp,
        "rewards": rewards.astype(np.float32),
        "terminated": np.ones((steps, envs), bool),
        "truncated": np.zeros((steps, envs), bool),
    }


def mean_distance_to_target(policy, rng):
    probe = rng.normal(size=(256, 3)).astype(np.float32)
    return float(np.linalg.norm(policy.mean(probe) - TARGET, axis=1).mean())


@pytest.mark.parametrize("optimizer, policy_lr", [("adam", 3e-3), ("sgd", 3e-2)])
def test_ppo_moves_policy_mean_towards_bandit_optimum(optimizer, policy_lr):
    learner = PPOLearner(3, 2, small_config(optimizer=optimizer, policy_lr=policy_lr))
    policy = NumpyPolicy(learner.policy_weights(), max_batch=64)
    rng = np.random.default_rng(0)
    before = mean_distance_to_target(policy, rng)
    for _ in range(8):
        metrics = learner.update(bandit_batch(policy, rng))
        policy.load_weights(learner.policy_weights())
    after = mean_distance_to_target(policy, rng)
    assert before > 0.5
    assert after < 0.35 * before, (before, after)
    assert set(CLEANRL_METRICS) <= set(metrics)
    assert all(np.isfinite(metrics[key]) for key in CLEANRL_METRICS)


def test_first_minibatch_sees_the_behaviour_policy():
    # With one gradient step over the whole batch, the reported ratio statistics are those
    # before any step: the learner must reproduce the workers' log-probabilities.
    learner = PPOLearner(3, 2, small_config(minibatch_size=512, update_epochs=1))
    policy = NumpyPolicy(learner.policy_weights(), max_batch=64)
    rng = np.random.default_rng(1)
    learner.update(bandit_batch(policy, rng))  # fits the normaliser
    policy.load_weights(learner.policy_weights())
    metrics = learner.update(bandit_batch(policy, rng))
    assert metrics["charts/gradient_steps"] == 1.0
    assert abs(metrics["losses/approx_kl"]) < 1e-6
    assert metrics["losses/clipfrac"] == 0.0


def snapshot(learner):
    state = learner.state_dict()
    tensors = {}
    for group in ("policy", "value", "normalizer"):
        for key, tensor in state[group].items():
            tensors[f"{group}.{key}"] = tensor.clone()
    for group in ("policy_optimizer", "value_optimizer"):
        for index, per_param in state[group]["state"].items():
            for key, tensor in per_param.items():
                tensors[f"{group}.{index}.{key}"] = tensor.clone()
    return tensors, state["numpy_rng"]


def assert_unchanged(learner, before):
    tensors, rng_state = snapshot(learner)
    assert tensors.keys() == before[0].keys()
    for key, tensor in tensors.items():
        assert torch.equal(tensor, before[0][key]), key
    assert rng_state == before[1]


@pytest.fixture
def trained_learner():
    """A learner after one good update, so that Adam moments and the normaliser are non-trivial."""
    learner = PPOLearner(3, 2, small_config())
    policy = NumpyPolicy(learner.policy_weights(), max_batch=64)
    rng = np.random.default_rng(2)
    learner.update(bandit_batch(policy, rng))
    return learner, policy, rng


@pytest.mark.parametrize("array", ["rewards", "obs", "next_obs", "actions", "logp"])
@pytest.mark.parametrize("bad_value", [np.nan, np.inf])
def test_non_finite_input_is_refused_and_leaves_learner_unchanged(trained_learner, array, bad_value):
    learner, policy, rng = trained_learner
    batch = bandit_batch(policy, rng)
    batch[array][3, 5] = bad_value
    before = snapshot(learner)
    with pytest.raises(NonFiniteError, match=f"batch\\['{array}'\\]"):
        learner.update(batch)
    assert_unchanged(learner, before)
    assert isinstance(NonFiniteError("x"), SfvError)


def test_loss_overflow_mid_update_restores_the_learner(trained_learner):
    learner, policy, rng = trained_learner
    batch = bandit_batch(policy, rng)
    # Put a finite but float32-overflowing value target in the *last* minibatch of the first
    # epoch (same shuffle as the learner's), so gradient steps have been taken before it fails.
    shuffle = np.random.default_rng()
    shuffle.bit_generator.state = learner.np_rng.bit_generator.state
    last_row = shuffle.permutation(batch["rewards"].size)[-1]
    batch["rewards"].reshape(-1)[last_row] = 3e38
    before = snapshot(learner)
    with pytest.raises(NonFiniteError, match="value loss"):
        learner.update(batch)
    assert_unchanged(learner, before)
    # The learner is still usable after the refused batch.
    metrics = learner.update(bandit_batch(policy, rng))
    assert np.isfinite(metrics["losses/value_loss"])


def test_malformed_batch_names_the_array():
    learner = PPOLearner(3, 2, small_config())
    policy = NumpyPolicy(learner.policy_weights())
    batch = bandit_batch(policy, np.random.default_rng(3))
    batch["actions"] = batch["actions"][:, :, :1]
    with pytest.raises(BatchFormatError, match=r"batch\['actions'\] has shape"):
        learner.update(batch)
    del batch["truncated"]
    with pytest.raises(BatchFormatError, match="missing arrays \\['truncated'\\]"):
        learner.update(batch)


def test_target_kl_stops_the_update_early():
    learner = PPOLearner(3, 2, small_config(policy_lr=3e-2, target_kl=1e-4))
    policy = NumpyPolicy(learner.policy_weights(), max_batch=64)
    metrics = learner.update(bandit_batch(policy, np.random.default_rng(4)))
    full_steps = 4 * 8  # epochs * (512 samples / 64)
    assert 1 <= metrics["charts/gradient_steps"] < full_steps
