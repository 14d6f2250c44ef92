"""GAE(lambda) advantages and TD(lambda) returns on time-major (T, N) rollout arrays.

Conventions shared by both functions (row t is one step of N parallel envs):

* ``values[t]`` = V(s_t), ``next_values[t]`` = V(s_{t+1}) of the true successor state,
  evaluated before any reset.
* ``terminated[t]``: s_{t+1} is terminal (the character fell); everything after it is
  worth 0, so nothing is bootstrapped.
* ``truncated[t]``: the episode was cut at a time limit; the future is estimated by
  ``next_values[t]``.
* Either flag ends the episode, so the recursion never looks past row t into the next
  episode.  The last row of the block is cut the same way (bootstrapped from
  ``next_values``), which is what lets workers ship fixed-length blocks mid-episode.

Inputs may be any float dtype; computation and outputs are float64.
"""

from __future__ import annotations

import numpy as np


def _check_shapes(**arrays: np.ndarray) -> tuple[int, int]:
    shapes = {name: np.shape(array) for name, array in arrays.items()}
    first = next(iter(shapes.values()))
    if len(first) != 2 or any(shape != first for shape in shapes.values()):
        raise ValueError(f"returns: expected equal (T, N) arrays, got shapes {shapes}")
    return first


def _episode_masks(terminated: np.ndarray, truncated: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(alive, continues) as float64: 0 where s_{t+1} is terminal / where the episode ends at t."""
    alive = 1.0 - np.asarray(terminated, dtype=np.float64)
    continues = 1.0 - np.asarray(np.logical_or(terminated, truncated), dtype=np.float64)
    return alive, continues


def gae_advantages(rewards: np.ndarray, values: np.ndarray, next_values: np.ndarray, terminated: np.ndarray,
                   truncated: np.ndarray, gamma: float, lam: float) -> np.ndarray:
    """A_t = delta_t + gamma * lam * A_{t+1} (within an episode), delta_t the TD error."""
    steps, _ = _check_shapes(
        rewards=rewards, values=values, next_values=next_values, terminated=terminated, truncated=truncated
    )
    alive, continues = _episode_masks(terminated, truncated)
    deltas = rewards + gamma * alive * next_values - np.asarray(values, dtype=np.float64)
    advantages = np.empty_like(deltas)
    running = np.zeros_like(deltas[0])
    for t in reversed(range(steps)):
        running = deltas[t] + gamma * lam * continues[t] * running
        advantages[t] = running
    return advantages


def td_lambda_returns(rewards: np.ndarray, next_values: np.ndarray, terminated: np.ndarray, truncated: np.ndarray,
                      gamma: float, lam: float) -> np.ndarray:
    """The lambda-return, recursively: G_t = r_t + gamma * ((1 - lam) V(s_{t+1}) + lam G_{t+1}).

    G_{t+1} is replaced by V(s_{t+1}) where the episode was truncated (or the block ends),
    and the whole bracket by 0 where it terminated.
    """
    steps, _ = _check_shapes(rewards=rewards, next_values=next_values, terminated=terminated, truncated=truncated)
    alive, continues = _episode_masks(terminated, truncated)
    next_values = np.asarray(next_values, dtype=np.float64)
    returns = np.empty(np.shape(rewards), dtype=np.float64)
    following = np.asarray(next_values[-1], dtype=np.float64)  # beyond the block: bootstrap
    for t in reversed(range(steps)):
        # Where the episode ends at t, the "lambda-return from t+1" is just V(s_{t+1}).
        following = np.where(continues[t] > 0.0, following, next_values[t])
        returns[t] = rewards[t] + gamma * alive[t] * ((1.0 - lam) * next_values[t] + lam * following)
        following = returns[t]
    return returns
