"""Is a compiled character its own mirror image? Its hinge mirror signs read off the model.

`mirror.py`'s maps are signed permutations built from what a character declares (`link_mirror`,
`joint_mirror`, `joint_mirror_sign`); this module checks the declaration against the compiled
MuJoCo model: at the zero pose (its own mirror image) partner links must sit at each other's
reflection in the x-z plane, their rest frames must reflect into each other, and each hinge's
partner must turn about +-S a, which gives its sign (S R(a, theta) S = R(-S a, theta): -1 where the
partner's axis is S a, +1 where it is -S a). The G1's MJCF is symmetric to 1e-5 m (its right
shoulder at y -0.10021 against the left's 0.10022; `tests/actors/character/test_g1_mirror.py`).
"""
from __future__ import annotations

import mujoco
import numpy as np

from learner.errors import SfvError

POLAR = np.array([1.0, -1.0, 1.0])  # S = diag(1, -1, 1), the reflection in the x-z plane: positions, linear velocities
AXIS_TOLERANCE = 1e-6  # a partner's world hinge axis must be +-S a to this (unit vectors)
FRAME_TOLERANCE = 1e-6  # partner links' rest orientations: R' = S R S to this (rotation matrix entries)
POSITION_TOLERANCE_M = 1e-3  # partner links' rest positions: x' = S x to this (the G1's MJCF: 1e-5 m)


def mirror_signs(character) -> np.ndarray:
    """(joints,) the character's `joint_mirror_sign` (a mirrored hinge angle is sign x its
    partner's; ball joints +1); an SfvError in one line for a body that declares none."""
    signs = getattr(character, "joint_mirror_sign", None)
    if signs is None:
        raise SfvError(f"the {character.name} declares no hinge mirror signs (joint_mirror_sign): it cannot be mirrored")
    signs = np.asarray(signs, dtype=np.float64)
    if signs.shape != (len(character.joint_names),) or not np.all(np.abs(signs) == 1.0):
        raise SfvError(f"the {character.name}'s joint_mirror_sign must be +1 or -1 per joint ({len(character.joint_names)})")
    return signs


def _rest_kinematics(compiled) -> mujoco.MjData:
    """The compiled character at its zero pose (root at the origin's vertical, unrotated; every
    joint at zero), which is its own mirror image whatever the signs."""
    model = compiled.model
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0
    data.qpos[:2] = 0.0
    data.qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
    mujoco.mj_kinematics(model, data)
    return data


def _joint_ids(compiled) -> np.ndarray:
    m = compiled.model
    return np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name) for name in compiled.character.joint_names])


def mirror_asymmetry(compiled) -> dict:
    """How far the compiled character is from its mirror image at the zero pose: the largest
    |x_partner - S x| of the links' world positions (m), |R_partner - S R S| of their
    orientations, and of each hinge's world axis from +-S a, with the links / joint named."""
    character, data = compiled.character, _rest_kinematics(compiled)
    ids, partner = compiled.body_ids, np.asarray(character.link_mirror)
    pos = np.abs(data.xpos[ids[partner]] - data.xpos[ids] * POLAR).max(axis=1)
    rot = data.xmat[ids].reshape(-1, 3, 3)
    frame = np.abs(rot[partner] - POLAR[:, None] * rot * POLAR).max(axis=(1, 2))
    axis = np.zeros(len(character.joint_names))
    hinges = np.flatnonzero(~np.asarray(character.joint_is_spherical))
    jid = _joint_ids(compiled)
    for j in hinges:
        reflected, theirs = POLAR * data.xaxis[jid[j]], data.xaxis[jid[character.joint_mirror[j]]]
        axis[j] = min(np.abs(theirs - reflected).max(), np.abs(theirs + reflected).max())
    return {"link_position_m": float(pos.max()), "link_position_link": character.link_names[int(pos.argmax())],
            "link_frame": float(frame.max()), "link_frame_link": character.link_names[int(frame.argmax())],
            "hinge_axis": float(axis.max()), "hinge_axis_joint": character.joint_names[int(axis.argmax())]}


def derive_hinge_mirror_signs(compiled) -> np.ndarray:
    """(joints,) the mirror sign of each joint, read off the compiled model: at the zero pose
    (its own mirror image) the world axis a' of hinge j's partner is compared with S a, S the
    reflection in the x-z plane: S R(a, theta) S = R(-S a, theta), so the mirrored angle is
    -theta where a' = S a and +theta where a' = -S a. Ball joints: +1 (mirrored as quaternions).
    A hinge whose partner's axis is neither, partner links whose rest frames do not reflect
    into each other, or partners further apart than POSITION_TOLERANCE_M from each other's
    reflection (not a symmetric body) are an SfvError naming the joint or link."""
    character, data = compiled.character, _rest_kinematics(compiled)
    found = mirror_asymmetry(compiled)
    if found["link_position_m"] > POSITION_TOLERANCE_M or found["link_frame"] > FRAME_TOLERANCE:
        raise SfvError(f"the {character.name} is not left/right symmetric in the x-z plane: {found['link_position_link']} is "
                       f"{found['link_position_m']:.3g} m and {found['link_frame_link']}'s frame {found['link_frame']:.3g} "
                       "from its partner's reflection")
    signs = np.ones(len(character.joint_names))
    jid = _joint_ids(compiled)
    for j in np.flatnonzero(~np.asarray(character.joint_is_spherical)):
        p = character.joint_mirror[j]
        reflected, theirs = POLAR * data.xaxis[jid[j]], data.xaxis[jid[p]]
        if np.abs(theirs - reflected).max() <= AXIS_TOLERANCE:
            signs[j] = -1.0
        elif np.abs(theirs + reflected).max() > AXIS_TOLERANCE:
            raise SfvError(f"the {character.name}'s {character.joint_names[j]} (axis {np.round(data.xaxis[jid[j]], 6).tolist()}) "
                           f"does not reflect onto {character.joint_names[p]}'s axis {np.round(theirs, 6).tolist()}: "
                           "not a symmetric body")
    return signs


def check_mirror_signs(compiled) -> np.ndarray:
    """The declared `joint_mirror_sign`, checked against the compiled model
    (`derive_hinge_mirror_signs`); a disagreement is an SfvError naming the joints."""
    character = compiled.character
    declared, derived = mirror_signs(character), derive_hinge_mirror_signs(compiled)
    wrong = [character.joint_names[j] for j in np.flatnonzero(declared != derived)]
    if wrong:
        raise SfvError(f"the {character.name}'s joint_mirror_sign disagrees with its model's hinge axes at {', '.join(wrong)}")
    return declared
