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

Humanoid3d experts only (`MIRROR_CHARACTERS`): the observation and action mirrors here are
the humanoid's, and the G1's hinge mirror signs have not been verified against its
simulation, so a G1 expert's mirror is refused in one line rather than guessed.
"""
from __future__ import annotations

import numpy as np

from actors.character.humanoid3d import Humanoid
from actors.character.mirror import MIRROR_SUFFIX, action_mirror, mirrored_name, observation_mirror
from learner.errors import SfvError
from services.experts.expert import Expert

MIRROR_CHARACTERS = ("humanoid3d",)  # the bodies whose experts are mirrored by symmetry


def check_mirror(clip: str, character: str) -> None:
    """One-line SfvError when `clip` is a `<clip>_mirror` and `character` has no mirrored experts."""
    if clip.endswith(MIRROR_SUFFIX) and character not in MIRROR_CHARACTERS:
        raise SfvError(f"sfv experts: {clip}: mirrored experts are {', '.join(MIRROR_CHARACTERS)}-only for now, "
                       f"not the {character}'s (its hinge mirror signs are not verified); "
                       f"train {clip.removesuffix(MIRROR_SUFFIX)} without the mirror")


class MirroredExpert(Expert):
    """`Expert`'s interface for `<clip>_mirror`, from the expert of `<clip>`.

    `act(obs)`: obs (B, obs_dim) are observations of an `ImitationEnv` on the mirrored clip
    with `env_config` (the original expert's settings); returns the mean actions (B, 28) for
    that env. Nothing else is needed: no state, no MjData, no reference."""

    def __init__(self, expert: Expert):
        check_mirror(mirrored_name(expert.name), expert.env_config.character)
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
