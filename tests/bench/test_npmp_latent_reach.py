"""bench/scripts/npmp_latent_reach.py: held latents give yaw rates and speeds, and the shipped module's
first principal direction steers a walker both ways."""
from __future__ import annotations

import numpy as np
import pytest

from bench.scripts.npmp_latent_reach import hold, summary


def test_the_summary_leaves_out_fallen_envs():
    held = {"rate": np.array([10.0, -5.0, 400.0]), "speed": np.array([1.0, 0.9, 9.0]), "fell": np.array([False, False, True])}
    row = summary(held)
    assert row["falls"] == pytest.approx(1 / 3, abs=1e-3)
    assert row["yaw_rate_deg_s"]["max"] == 10.0 and row["speed_m_s"]["max"] == 1.0


def test_the_first_principal_direction_turns_a_walker_left_and_right():
    from actors.envs.tasks.config import TaskEnvConfig
    from actors.envs.tasks.vector_task_env import VectorTaskEnv

    env = VectorTaskEnv(TaskEnvConfig(latent_directions=2, start_motion="deepmimic:walk"), 4, seed=0)
    rates = []
    for sign in (-1.0, 1.0):
        actions = np.zeros((4, env.action_dim), np.float32)
        actions[:, 0] = sign
        held = hold(env, actions)
        assert np.isfinite(held["rate"]).all() and (held["speed"] > 0.3).all()  # walking, not standing
        rates.append(np.median(held["rate"][~held["fell"]]))
    assert rates[0] < -15.0 < 15.0 < rates[1]  # measured: -49 and +56 deg/s over 32 starts
