"""PPO on batches drawn by older weights (the asynchronous loop): decoupled clipping."""
from __future__ import annotations

import numpy as np
import torch

from learner.policy import NumpyPolicy
from learner.ppo import PPOLearner, clipped_surrogate_loss, decoupled_surrogate_loss
from tests.learner.test_learner_ppo import bandit_batch, mean_distance_to_target, small_config


def test_decoupled_loss_is_the_clipped_loss_when_the_behaviour_is_the_proximal_policy():
    g = torch.Generator().manual_seed(0)
    new, old, adv = torch.randn(64, generator=g), torch.randn(64, generator=g), torch.randn(64, generator=g)
    plain, _, _ = clipped_surrogate_loss(new, old, adv, 0.2)
    decoupled, _, _ = decoupled_surrogate_loss(new, old, old, adv, 0.2, max_weight=2.0)
    assert torch.allclose(plain, decoupled)


def test_decoupled_loss_clips_around_the_proximal_policy_and_truncates_the_weight():
    prox = torch.zeros(2)
    behaviour = torch.tensor([0.0, -5.0])  # the second action was far less likely under the behaviour policy
    new = torch.tensor([0.5, 0.0], requires_grad=True)  # the first ratio to prox is e^.5 = 1.65: clipped for A > 0
    adv = torch.ones(2)
    loss, ratio, _ = decoupled_surrogate_loss(new, prox, behaviour, adv, 0.2, max_weight=2.0)
    loss.backward()
    assert new.grad[0] == 0.0  # beyond 1 + eps against prox: no gradient, although it is the behaviour's 1.65 too
    assert torch.isclose(new.grad[1], torch.tensor(-2.0 / 2))  # weight e^5 truncated to 2, mean over 2 rows
    assert torch.isclose(ratio[1], torch.tensor(1.0))


def test_a_lagged_batch_starts_its_update_at_the_learners_own_policy():
    learner = PPOLearner(3, 2, small_config(minibatch_size=512, update_epochs=1))
    behaviour = NumpyPolicy(learner.policy_weights(), max_batch=64)
    rng = np.random.default_rng(1)
    learner.update(bandit_batch(behaviour, rng))  # fits the normaliser
    behaviour.load_weights(learner.policy_weights())
    learner.update(bandit_batch(behaviour, rng))  # the learner moves on; `behaviour` stays one version behind
    lagged = bandit_batch(behaviour, rng)
    as_if_on_policy = PPOLearner(3, 2, small_config(minibatch_size=512, update_epochs=1))
    as_if_on_policy.load_state_dict(learner.state_dict())
    stale_kl = as_if_on_policy.update(dict(lagged))["losses/approx_kl"]
    decoupled_kl = learner.update({**lagged, "policy_lag": 1})["losses/approx_kl"]
    assert abs(decoupled_kl) < 1e-6  # ratio 1 against the learner's weights at the first step
    assert stale_kl > 1e-4  # read as on-policy, the batch already sits away from ratio 1


def test_ppo_learns_the_bandit_from_batches_one_version_old():
    learner = PPOLearner(3, 2, small_config())
    behaviour = NumpyPolicy(learner.policy_weights(), max_batch=64)
    rng = np.random.default_rng(0)
    before = mean_distance_to_target(behaviour, rng)
    for _ in range(10):
        batch = bandit_batch(behaviour, rng)
        behaviour.load_weights(learner.policy_weights())  # the workers got the newest weights while the learner updates
        learner.update({**batch, "policy_lag": 1})
    after = mean_distance_to_target(NumpyPolicy(learner.policy_weights(), max_batch=64), rng)
    assert after < 0.35 * before, (before, after)
