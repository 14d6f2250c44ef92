"""The expert of a mirrored clip, by symmetry instead of training (NPMP data, 004 §3.3).

The humanoid is left/right symmetric (`actors/character/mirror.py`), so a policy pi tracking clip C
gives the policy for C_mirror exactly: pi_mirror(o) = M_a(pi(M_o(o))), with M_o the mirror
of the observation and M_a the mirror of the action (both signed permutations, their own
inverses). Reading the observation back through M_o is the same as mirroring the simulated
state back into a scratch MjData and computing the original clip's observation there with a
`FeatureExtractor` (tested to be equal), without the MuJoCo calls: observations are in the
root's heading frame and every term (links, velocities, future reference roots, phase)
mirrors. The only differences from a trained mirrored expert are MuJoCo's own numerical
asymmetries (contact order, solver), which the eval NR measures (`sfv experts table`).
"""
from __future__ import annotations

import numpy as np

from actors.character.humanoid3d import Humanoid
from actors.character.mirror import action_mirror, mirrored_name, observation_mirror
from services.experts.expert import Expert


class MirroredExpert(Expert):
    """`Expert`'s interface for `<clip>_mirror`, from the expert of `<clip>`.

    `act(obs)`: obs (B, obs_dim) are observations of an `ImitationEnv` on the mirrored clip
    with `env_config` (the original expert's settings); returns the mean actions (B, 28) for
    that env. Nothing else is needed: no state, no MjData, no reference."""

    def __init__(self, expert: Expert):
        super().__init__(expert.policy, expert.env_config, mirrored_name(expert.motion), mirrored_name(expert.name))
        self.expert = expert
        humanoid = Humanoid(expert.env_config.physics)
        self.observation_map = observation_mirror(humanoid, len(expert.env_config.reference_obs_steps),
                                                  len(expert.env_config.reference_pose_obs_steps))
        self.action_map = action_mirror(expert.env_config.action_parameterisation)

    def act(self, obs: np.ndarray) -> np.ndarray:
        original = self.observation_map(np.asarray(obs, dtype=np.float32))
        return self.action_map(self.expert.act(original)).astype(np.float32)

    mean = act
