"""Annealing of the policy learning rate and exploration std (learner/schedule.py, PPOLearner.set_progress)."""

import numpy as np
import pytest

from learner.policy import NumpyPolicy
from learner.ppo import PPOLearner
from learner.schedule import ADAPTIVE_LR_MAX, ADAPTIVE_LR_MIN, adapt_rate_to_kl, linear_anneal
from tests.learner.test_learner_ppo import bandit_batch, small_config


def test_linear_anneal_runs_from_start_to_final_then_holds():
    values = [linear_anneal(4.0, 1.0, s, 100) for s in (0, 25, 50, 100, 1000)]
    assert values == pytest.approx([4.0, 3.25, 2.5, 1.0, 1.0])
    assert linear_anneal(4.0, None, 10**9, 100) == 4.0


def _probe_mean(learner, probe):
    return NumpyPolicy(learner.policy_weights(), max_batch=len(probe)).mean(probe)


def test_annealed_learning_rate_shrinks_the_step():
    # Same learner, same batch: at the end of the anneal the policy moves ~lr_final / lr as far
    # (Adam's first step is lr-sized per parameter).
    config = dict(policy_lr=3e-3, policy_lr_final=3e-4, anneal_samples=1000, minibatch_size=512, update_epochs=1)
    probe = np.random.default_rng(5).normal(size=(64, 3)).astype(np.float32)
    moves = []
    for samples in (0, 1000):
        learner = PPOLearner(3, 2, small_config(**config))
        rng = np.random.default_rng(2)
        learner.update(bandit_batch(NumpyPolicy(learner.policy_weights(), max_batch=64), rng))  # fits the normaliser
        learner.set_progress(samples)
        before = _probe_mean(learner, probe)
        learner.update(bandit_batch(NumpyPolicy(learner.policy_weights(), max_batch=64), rng))
        moves.append(float(np.abs(_probe_mean(learner, probe) - before).mean()))
    assert moves[0] > 0
    assert 0.03 < moves[1] / moves[0] < 0.3, moves


def test_annealed_std_reaches_the_workers_and_the_update_agrees_with_them():
    learner = PPOLearner(3, 2, small_config(action_std=0.4, action_std_final=0.1, anneal_samples=100,
                                            minibatch_size=512, update_epochs=1))
    rng = np.random.default_rng(3)
    learner.update(bandit_batch(NumpyPolicy(learner.policy_weights(), max_batch=64), rng))
    learner.set_progress(50)
    policy = NumpyPolicy(learner.policy_weights(), max_batch=64)
    batch = bandit_batch(policy, rng)
    assert batch["actions"].std() == pytest.approx(0.25, rel=0.2)  # the workers sample with the annealed std
    metrics = learner.update(batch)
    # The first (only) minibatch's ratios are those of the behaviour policy: the learner's
    # log-probabilities use the same std the batch was sampled with.
    assert abs(metrics["losses/approx_kl"]) < 1e-6
    assert metrics["losses/clipfrac"] == 0.0


def test_adaptive_rate_follows_the_kl_within_its_bounds():
    assert adapt_rate_to_kl(1e-4, 0.05, 0.01) == pytest.approx(1e-4 / 1.5)  # moved too far
    assert adapt_rate_to_kl(1e-4, 0.001, 0.01) == pytest.approx(1.5e-4)  # barely moved
    assert adapt_rate_to_kl(1e-4, 0.01, 0.01) == 1e-4  # within [desired / 2, 2 desired]
    assert adapt_rate_to_kl(ADAPTIVE_LR_MAX, 0.0, 0.01) == ADAPTIVE_LR_MAX
    assert adapt_rate_to_kl(ADAPTIVE_LR_MIN, 1.0, 0.01) == ADAPTIVE_LR_MIN


def _adaptive_learner(desired_kl):
    return PPOLearner(3, 2, small_config(policy_lr=1e-5, desired_kl=desired_kl, minibatch_size=64, update_epochs=2))


def test_adaptive_rate_rises_on_a_timid_step_and_survives_a_resume():
    learner = _adaptive_learner(0.01)
    rng = np.random.default_rng(4)
    for _ in range(3):
        metrics = learner.update(bandit_batch(NumpyPolicy(learner.policy_weights(), max_batch=64), rng))
        learner.set_progress(100)  # the driver's call between updates must not reset it
    assert learner.policy_lr > 1e-5 * 1.5  # 1e-5 moves this small net far less than KL .005
    assert metrics["charts/policy_lr"] == learner.policy_lr
    assert learner.policy_optimizer.param_groups[0]["lr"] == learner.policy_lr
    resumed = _adaptive_learner(0.01)
    resumed.load_state_dict(learner.state_dict())
    assert resumed.policy_lr == learner.policy_lr
    fixed = PPOLearner(3, 2, small_config(policy_lr=1e-5, minibatch_size=64, update_epochs=2))
    fixed.load_state_dict(learner.state_dict())  # a run without the option keeps its own rate
    assert fixed.policy_optimizer.param_groups[0]["lr"] == 1e-5


def test_adaptive_rate_refuses_an_anneal_too():
    with pytest.raises(Exception, match="desired_kl"):
        small_config(desired_kl=0.01, policy_lr_final=1e-6)
