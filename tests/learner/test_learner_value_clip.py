"""PPO value targets clipped to [0, reward_max / (1 - gamma)] (DeepMimic's val_min/val_max):
with rewards in [0, reward_max] no return lies outside it.

Every transition here ends its episode (terminated), so each TD(lambda) target is just its
reward: the targets the value network is fitted to are known without the learner's help.
They are read where the learner hands them to each gradient step.
"""
import numpy as np
import pytest
import torch

from learner.config import PPOConfig
from learner.errors import ConfigError
from learner.ppo import PPOLearner
from tests.learner_helpers import behaviour_rollout

GAMMA = 0.9  # bound 1 / (1 - 0.9) = 10 with reward_max 1
STEPS, ENVS, OBS, ACT = 4, 32, 3, 2


def config(**overrides):
    values = dict(policy_hidden=(16,), value_hidden=(16,), minibatch_size=32, update_epochs=2, gamma=GAMMA,
                  target_kl=None, seed=0)
    values.update(overrides)
    return PPOConfig(**values)


def batch_with_rewards(learner, rewards):
    rng = np.random.default_rng(1)
    batch = behaviour_rollout(learner, rng, STEPS, ENVS, OBS)
    return {**batch, "next_obs": rng.normal(size=batch["obs"].shape).astype(np.float32),
            "rewards": rewards.astype(np.float32), "terminated": np.ones((STEPS, ENVS), bool),
            "truncated": np.zeros((STEPS, ENVS), bool)}


def targets_seen(learner, batch):
    """The sorted value targets of the first epoch's gradient steps."""
    seen = []
    step = learner._gradient_step

    def spy(obs_norm, actions, old_logp, advantages, value_targets):
        seen.append(value_targets.detach().cpu().numpy().copy())
        return step(obs_norm, actions, old_logp, advantages, value_targets)

    learner._gradient_step = spy
    try:
        learner.update(batch)
    finally:
        del learner._gradient_step
    per_epoch = STEPS * ENVS // 32
    return np.sort(np.concatenate(seen[:per_epoch]))


@pytest.fixture
def rewards():
    rewards = np.random.default_rng(0).uniform(-5.0, 15.0, size=(STEPS, ENVS))
    rewards[0, :3] = [-2.0, 12.0, 10.5]
    return rewards


def test_targets_above_the_bound_and_below_zero_are_clipped(rewards):
    learner = PPOLearner(OBS, ACT, config(reward_max=1.0))
    seen = targets_seen(learner, batch_with_rewards(learner, rewards))
    expected = np.sort(np.clip(rewards.astype(np.float32).ravel(), 0.0, 10.0))
    np.testing.assert_allclose(seen, expected, rtol=1e-6, atol=1e-6)
    assert seen.max() == pytest.approx(10.0) and seen.min() == 0.0
    assert (rewards > 10.0).sum() > 10 and (rewards < 0.0).sum() > 10  # both bounds were hit


def test_the_bound_scales_with_reward_max_and_gamma(rewards):
    learner = PPOLearner(OBS, ACT, config(reward_max=0.5, gamma=0.95))  # 0.5 / 0.05 = 10 as well
    seen = targets_seen(learner, batch_with_rewards(learner, rewards))
    assert seen.max() == pytest.approx(10.0)
    learner = PPOLearner(OBS, ACT, config(reward_max=0.2))  # 0.2 / 0.1 = 2
    seen = targets_seen(learner, batch_with_rewards(learner, rewards))
    assert seen.max() == pytest.approx(2.0) and seen.min() == 0.0


def test_none_disables_the_clip(rewards):
    learner = PPOLearner(OBS, ACT, config(reward_max=None))
    seen = targets_seen(learner, batch_with_rewards(learner, rewards))
    np.testing.assert_allclose(seen, np.sort(rewards.astype(np.float32).ravel()), rtol=1e-6, atol=1e-6)
    assert seen.max() > 10.0 and seen.min() < 0.0


def test_in_range_targets_are_untouched():
    in_range = np.random.default_rng(2).uniform(0.0, 1.0, size=(STEPS, ENVS))
    learner = PPOLearner(OBS, ACT, config())  # the default: reward_max 1
    seen = targets_seen(learner, batch_with_rewards(learner, in_range))
    np.testing.assert_allclose(seen, np.sort(in_range.astype(np.float32).ravel()), rtol=1e-6, atol=1e-6)


def value_everywhere(learner, value):
    """Make the value network output `value` for any input (last layer: zero weights)."""
    with torch.no_grad():
        last = [m for m in learner.value.modules() if isinstance(m, torch.nn.Linear)][-1]
        last.weight.zero_()
        last.bias.fill_(value)


def test_bootstrapped_targets_are_clipped_too():
    """A truncated episode bootstraps from V(next_obs): a value network far above the bound
    still yields targets within it."""
    learner = PPOLearner(OBS, ACT, config(reward_max=1.0, td_lambda=0.0))
    value_everywhere(learner, 1000.0)
    batch = batch_with_rewards(learner, np.full((STEPS, ENVS), 0.5))
    batch["terminated"][:] = False
    batch["truncated"][:] = True
    seen = targets_seen(learner, batch)
    np.testing.assert_allclose(seen, 10.0, rtol=1e-6)  # 0.5 + 0.9 * 1000, clipped
    learner = PPOLearner(OBS, ACT, config(reward_max=None, td_lambda=0.0))
    value_everywhere(learner, 1000.0)
    seen = targets_seen(learner, batch)
    np.testing.assert_allclose(seen, 0.5 + GAMMA * 1000.0, rtol=1e-5)


def test_reward_max_must_be_positive():
    for bad in (0.0, -1.0):
        with pytest.raises(ConfigError, match="reward_max"):
            config(reward_max=bad)
