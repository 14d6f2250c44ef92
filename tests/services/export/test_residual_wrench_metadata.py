"""The runtime metadata of a policy trained with a residual root wrench names its last six outputs."""
from __future__ import annotations

import numpy as np

from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.motion.formats.io import load_motion
from services.export.runtime_metadata import _action


def test_the_wrench_is_the_actions_tail_and_no_actuator():
    walk = load_motion("deepmimic:walk")
    plain = _action(ImitationEnv(walk, EnvConfig()))
    helped_env = ImitationEnv(walk, EnvConfig(residual_force=0.5))
    helped = _action(helped_env)
    assert plain["residual_wrench"] is None and plain["dim"] == helped["dim"] == 28
    wrench = helped["residual_wrench"]
    assert wrench["dims"] == [28, 34] == [helped["dim"], helped_env.action_space.shape[0]]
    np.testing.assert_allclose(wrench["scale"], helped_env.core.residual.scale)
    assert wrench["scale"][0] > 100.0 and "no such actuator" in wrench["what"]
