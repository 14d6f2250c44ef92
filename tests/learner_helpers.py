"""Shared by the learner tests: behaviour-policy actions for random observations."""
from __future__ import annotations

import numpy as np

from learner.policy import NumpyPolicy


def behaviour_rollout(learner, rng: np.random.Generator, steps: int, envs: int, obs_dim: int) -> dict[str, np.ndarray]:
    """Random observations and the learner's own sampled actions and log-probabilities for them,
    as a rollout worker would have collected them (time-major)."""
    policy = NumpyPolicy(learner.policy_weights(), max_batch=envs)
    obs = rng.normal(size=(steps, envs, obs_dim)).astype(np.float32)
    actions = np.empty((steps, envs, policy.act_dim), np.float32)
    logp = np.empty((steps, envs), np.float32)
    for t in range(steps):
        policy.act(obs[t], rng, out_actions=actions[t], out_logp=logp[t])
    return {"obs": obs, "actions": actions, "logp": logp}
