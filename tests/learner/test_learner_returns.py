"""GAE(lambda) and TD(lambda) against hand-worked numbers and brute-force forward views."""

import numpy as np
import pytest

from learner.returns import gae_advantages, td_lambda_returns

GAMMA, LAM = 0.5, 0.5


def column(values, dtype=np.float64):
    return np.asarray(values, dtype=dtype).reshape(-1, 1)


# Worked by hand: r = 1 each step, V(s_0..s_3) = 1, 2, 4, 8, gamma = lambda = 0.5.
#   terminated at t=2:  delta = [1 + .5*2 - 1, 1 + .5*4 - 2, 1 + 0 - 4] = [1, 1, -3]
#                       A_2 = -3, A_1 = 1 + .25*(-3) = .25, A_0 = 1 + .25*.25 = 1.0625
#                       G_2 = 1, G_1 = 1 + .5*(.5*4 + .5*1) = 2.25, G_0 = 1 + .5*(.5*2 + .5*2.25) = 2.0625
#   truncated at t=2:   delta_2 = 1 + .5*8 - 4 = 1 -> A = [1.3125, 1.25, 1]
#                       G_2 = 1 + .5*8 = 5, G_1 = 1 + .5*(2 + 2.5) = 3.25, G_0 = 1 + .5*(1 + 1.625) = 2.3125
REWARDS = column([1.0, 1.0, 1.0])
VALUES = column([1.0, 2.0, 4.0])
NEXT_VALUES = column([2.0, 4.0, 8.0])
AT_END = column([False, False, True], bool)
NEVER = column([False, False, False], bool)


def test_terminated_episode_matches_hand_computation():
    advantages = gae_advantages(REWARDS, VALUES, NEXT_VALUES, AT_END, NEVER, GAMMA, LAM)
    returns = td_lambda_returns(REWARDS, NEXT_VALUES, AT_END, NEVER, GAMMA, LAM)
    np.testing.assert_allclose(advantages.ravel(), [1.0625, 0.25, -3.0])
    np.testing.assert_allclose(returns.ravel(), [2.0625, 2.25, 1.0])


def test_truncated_episode_bootstraps_from_next_value():
    advantages = gae_advantages(REWARDS, VALUES, NEXT_VALUES, NEVER, AT_END, GAMMA, LAM)
    returns = td_lambda_returns(REWARDS, NEXT_VALUES, NEVER, AT_END, GAMMA, LAM)
    np.testing.assert_allclose(advantages.ravel(), [1.3125, 1.25, 1.0])
    np.testing.assert_allclose(returns.ravel(), [2.3125, 3.25, 5.0])


def random_rollout(seed, steps=12, envs=5):
    """Episodes with both kinds of ends; after an end, s_{t+1} is a reset state whose value
    differs from the successor value stored at the end step."""
    rng = np.random.default_rng(seed)
    rewards = rng.normal(size=(steps, envs))
    values = rng.normal(size=(steps, envs))
    terminated = rng.random((steps, envs)) < 0.15
    truncated = ~terminated & (rng.random((steps, envs)) < 0.15)
    next_values = np.empty_like(values)
    next_values[:-1] = values[1:]
    next_values[-1] = rng.normal(size=envs)
    ended = terminated | truncated
    next_values[ended] = rng.normal(size=ended.sum()) * 10.0  # true successor, not the reset state
    return rewards, values, next_values, terminated, truncated


def episode_end(t, env, terminated, truncated):
    """Last step index of the episode (or block) that contains step t."""
    k = t
    while k < terminated.shape[0] - 1 and not (terminated[k, env] or truncated[k, env]):
        k += 1
    return k


def brute_force_gae(rewards, values, next_values, terminated, truncated, gamma, lam):
    steps, envs = rewards.shape
    out = np.zeros_like(rewards)
    for env in range(envs):
        for t in range(steps):
            end = episode_end(t, env, terminated, truncated)
            for k in range(t, end + 1):
                bootstrap = 0.0 if terminated[k, env] else next_values[k, env]
                delta = rewards[k, env] + gamma * bootstrap - values[k, env]
                out[t, env] += (gamma * lam) ** (k - t) * delta
    return out


def brute_force_lambda_return(rewards, next_values, terminated, truncated, gamma, lam):
    """Forward view: (1 - lam) * sum_n lam^(n-1) G^(n) + lam^(L-1) * (full return of the L steps)."""
    steps, envs = rewards.shape
    out = np.zeros_like(rewards)
    for env in range(envs):
        for t in range(steps):
            end = episode_end(t, env, terminated, truncated)
            length = end - t + 1

            def n_step(n):
                discounted = sum(gamma**i * rewards[t + i, env] for i in range(n))
                last = t + n - 1
                tail = 0.0 if (last == end and terminated[last, env]) else next_values[last, env]
                return discounted + gamma**n * tail

            out[t, env] = sum((1 - lam) * lam ** (n - 1) * n_step(n) for n in range(1, length)) + lam ** (
                length - 1
            ) * n_step(length)
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("gamma, lam", [(0.95, 0.95), (0.9, 0.0), (0.99, 1.0)])
def test_gae_matches_brute_force(seed, gamma, lam):
    rewards, values, next_values, terminated, truncated = random_rollout(seed)
    expected = brute_force_gae(rewards, values, next_values, terminated, truncated, gamma, lam)
    got = gae_advantages(rewards, values, next_values, terminated, truncated, gamma, lam)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("gamma, lam", [(0.95, 0.95), (0.9, 0.0), (0.99, 1.0)])
def test_td_lambda_matches_forward_view(seed, gamma, lam):
    rewards, _, next_values, terminated, truncated = random_rollout(seed)
    expected = brute_force_lambda_return(rewards, next_values, terminated, truncated, gamma, lam)
    got = td_lambda_returns(rewards, next_values, terminated, truncated, gamma, lam)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("seed", [3, 4])
def test_advantage_plus_value_is_lambda_return(seed):
    # With next_values[t] == values[t+1] inside episodes, GAE + V equals the lambda-return.
    rewards, values, next_values, terminated, truncated = random_rollout(seed, steps=20, envs=7)
    advantages = gae_advantages(rewards, values, next_values, terminated, truncated, 0.95, 0.95)
    returns = td_lambda_returns(rewards, next_values, terminated, truncated, 0.95, 0.95)
    np.testing.assert_allclose(advantages + values, returns, rtol=1e-12, atol=1e-12)


def test_mismatched_shapes_are_rejected():
    with pytest.raises(ValueError, match="shapes"):
        gae_advantages(REWARDS, VALUES[:2], NEXT_VALUES, AT_END, NEVER, GAMMA, LAM)
