"""The expert of a mirrored clip, by symmetry instead of training (NPMP data, 004 §3.3).

Both bodies are left/right symmetric (`actors/character/mirror.py`: humanoid3d exactly, the
Unitree G1's MJCF to 1e-5 m, its hinge mirror signs read off its model), so a policy pi tracking
clip C gives the policy for C_mirror: pi_mirror(o) = M_a(pi(M_o(o))), with M_o the mirror
of the observation and M_a the mirror of the action (both signed permutations, their own
inverses; a hinge's entry its partner's times the joint's mirror sign). Reading the observation
back through M_o is the same as mirroring the simulated state back into a scratch MjData and
computing the original clip's observation there with a `FeatureExtractor` (tested to be equal,
for both bodies), without the MuJoCo calls: observations are in the root's heading frame and
every term (links, velocities, future reference roots, phase) mirrors. The only differences
from a trained mirrored expert are MuJoCo's own numerical asymmetries (contact order, solver)
and, on the G1, its MJCF's small ones (a 1e-5 m shoulder offset, the torso's centre of mass
0.34 mm off the plane, one sole capsule 1 mm off at one end), which the eval NR measures
(`sfv experts table`). On the G1, `deepmimic:<clip>_mirror` is the mirrored humanoid clip
retargeted at load, as any humanoid clip is.

Any registered character that declares its mirror maps and hinge mirror signs
(`mirror.can_mirror`) has mirrored experts (`MIRROR_CHARACTERS`); `check_mirror` refuses the
mirror of another body's expert in one line.
"""
from __future__ import annotations

import numpy as np

from actors.character.characters import CHARACTER_NAMES, character_named
from actors.character.mirror import MIRROR_SUFFIX, action_mirror, can_mirror, mirrored_name, observation_mirror
from learner.errors import SfvError
from services.experts.expert import Expert

# the bodies whose experts are mirrored by symmetry: those that declare their hinge mirror signs
MIRROR_CHARACTERS = tuple(name for name in CHARACTER_NAMES if can_mirror(character_named(name)))


def check_mirror(clip: str, character: str) -> None:
    """One-line SfvError when `clip` is a `<clip>_mirror` and `character` has no mirrored experts."""
    if clip.endswith(MIRROR_SUFFIX) and character not in MIRROR_CHARACTERS:
        raise SfvError(f"sfv experts: {clip}: mirrored experts are for {', '.join(MIRROR_CHARACTERS)}, "
                       f"not the {character} (it declares no hinge mirror signs); "
                       f"train {clip.removesuffix(MIRROR_SUFFIX)} without the mirror")


class MirroredExpert(Expert):
    """`Expert`'s interface for `<clip>_mirror`, from the expert of `<clip>`.

    `act(obs)`: obs (B, obs_dim) are observations of an `ImitationEnv` on the mirrored clip
    with `env_config` (the original expert's settings, its body `env_config.character`); returns
    the mean actions (B, act_dim: 28 humanoid3d, 29 g1) for that env. Nothing else is needed: no
    state, no MjData, no reference (the body is compiled once, for its body ids and to check
    its mirror signs)."""

    def __init__(self, expert: Expert):
        check_mirror(mirrored_name(expert.name), expert.env_config.character)
        super().__init__(expert.policy, expert.env_config, mirrored_name(expert.motion), mirrored_name(expert.name))
        self.expert = expert
        character = character_named(expert.env_config.character)
        body = character.build(expert.env_config.physics)
        self.observation_map = observation_mirror(body, len(expert.env_config.reference_obs_steps),
                                                  len(expert.env_config.reference_pose_obs_steps))
        self.action_map = action_mirror(expert.env_config.action_parameterisation, character)

    def act(self, obs: np.ndarray) -> np.ndarray:
        original = self.observation_map(np.asarray(obs, dtype=np.float32))
        return self.action_map(self.expert.act(original)).astype(np.float32)

    mean = act
