"""What the static pipeline says of a controller with a residual root wrench
(`actors/envs/residual_force.py`): how much help it used, and the same episode without it."""
from __future__ import annotations

import numpy as np
import pytest

from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.motion.formats.io import load_motion


@pytest.fixture(scope="module")
def walk():
    return load_motion("deepmimic:walk")


class _Constant:
    def __init__(self, action):
        self.action = action

    def mean(self, obs):
        return self.action[None]


def test_the_report_says_how_much_help_the_controller_used(walk):
    from services.pipeline.report import build_report
    from services.pipeline.rollout import first_frame_rollout

    env = ImitationEnv(walk, EnvConfig(residual_force=0.4))
    action = np.zeros(env.action_space.shape[0])
    action[-6:-3] = [0.0, 0.6, 0.8]  # |a_force| = 1: 0.4 of body weight
    rollout = first_frame_rollout(_Constant(action), env)
    np.testing.assert_allclose(rollout.residual_force, 0.4)
    report, _, _ = build_report(rollout, env.humanoid, walk)
    assert report["residual_force_body_weight"] == {"mean": pytest.approx(0.4), "max": pytest.approx(0.4)}
    plain = ImitationEnv(walk, EnvConfig())
    unaided = first_frame_rollout(_Constant(np.zeros(plain.action_space.shape[0])), plain)
    assert unaided.residual_force is None and build_report(unaided, plain.humanoid, walk)[0]["residual_force_body_weight"] is None


def test_without_the_wrench_the_same_policy_gets_no_help(walk):
    from services.pipeline.rollout import WithoutWrench, first_frame_rollout

    env = ImitationEnv(walk, EnvConfig(residual_force=0.4))
    action = np.full(env.action_space.shape[0], 0.3)
    alone = first_frame_rollout(WithoutWrench(_Constant(action)), env)
    np.testing.assert_array_equal(alone.residual_force, 0.0)
    helped = first_frame_rollout(_Constant(action), env)
    assert helped.residual_force.min() > 0.1  # the same policy with its wrench


def test_the_outcome_line_says_the_help_and_how_the_body_alone_does():
    from services.pipeline.finish import _help_clause

    needed = _help_clause({"mean": 0.1137, "max": 0.19}, {"fell": True, "fell_at_s": 1.233, "normalized_return": 0.47})
    assert needed == "; with a residual root force of 11 % of body weight on average (without it: falls at 1.23 s)"
    spare = _help_clause({"mean": 0.004, "max": 0.02}, {"fell": False, "fell_at_s": None, "normalized_return": 0.9})
    assert spare.endswith("of 0 % of body weight on average (without it: completes it too)")
