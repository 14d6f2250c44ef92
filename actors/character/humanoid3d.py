"""humanoid3d: DeepMimic's humanoid (SFV's character) as a `Character` (`actors/character/base.py`).

Its numbers live in `skeleton.py` (links, joints, gains, masses, left/right partners, reward
weights), its MJCF in `humanoid.py`; this module gathers them behind the interface and holds
the compiled model, `Humanoid` (a `CompiledCharacter`), which carries its description as `character`.
"""
from __future__ import annotations

import numpy as np

from actors.arenas.flat import FlatFloor
from actors.character import skeleton
from actors.character.compiled import CompiledCharacter
from actors.character.humanoid import PhysicsConfig, build_mjcf


class Humanoid3D:
    name = "humanoid3d"
    link_names = skeleton.LINK_NAMES
    num_links = skeleton.NUM_LINKS
    joint_names = skeleton.JOINT_NAMES
    joint_is_spherical = skeleton.JOINT_IS_SPHERICAL
    joint_links = np.array(skeleton.JOINT_LINKS)  # the humanoid's joints are named after the links they move
    nu = skeleton.NUM_ACTUATED_DOF  # 28
    nq = 7 + 4 * int(skeleton.JOINT_IS_SPHERICAL.sum()) + int((~skeleton.JOINT_IS_SPHERICAL).sum())  # 43
    nv = 6 + nu  # 34
    hinge_axes = np.tile(skeleton.HINGE_AXIS, (int((~skeleton.JOINT_IS_SPHERICAL).sum()), 1))  # every hinge turns about one axis
    actuator_limits = skeleton.actuator_limits()
    default_joint_pos = np.zeros(skeleton.NUM_ACTUATED_DOF)  # its zero pose stands straight
    kp = np.array([skeleton.LINKS[i].kp for i in skeleton.JOINT_LINKS])
    kd = np.array([skeleton.LINKS[i].kd for i in skeleton.JOINT_LINKS])
    torque_limits = np.array([skeleton.LINKS[i].torque_limit for i in skeleton.JOINT_LINKS])
    residual_scale_factors = np.ones(skeleton.NUM_ACTUATED_DOF)  # the residual range is residual_action_scale rad on every axis
    end_effector_links = skeleton.END_EFFECTOR_LINKS
    feet = ("right_ankle", "left_ankle")
    torso_links = skeleton.FALL_CONTACT_LINKS
    fall_contact_geoms = tuple(f"{skeleton.LINK_NAMES[i]}_geom" for i in skeleton.FALL_CONTACT_LINKS)  # one geom a link
    link_mirror = skeleton.LINK_MIRROR
    joint_mirror = skeleton.JOINT_MIRROR
    joint_mirror_sign = np.ones(len(skeleton.JOINT_NAMES))  # its hinges turn about (0, -1, 0), in the sagittal plane: the same angle
    reward_joint_weights = skeleton.DEEPMIMIC_JOINT_WEIGHTS

    def mjcf(self, physics: PhysicsConfig = PhysicsConfig(), arena=None) -> str:
        return build_mjcf(physics, arena)

    def build(self, physics: PhysicsConfig = PhysicsConfig(), arena=None) -> Humanoid:
        return Humanoid(physics, arena)


HUMANOID3D = Humanoid3D()


class Humanoid(CompiledCharacter):
    """The compiled humanoid3d (its MJCF from `humanoid.py`, in an arena) and the index maps
    between skeleton order and MuJoCo order; `character` is the description it was built from
    (what features, actions and mirror maps read)."""

    def __init__(self, config: PhysicsConfig = PhysicsConfig(), arena=None):
        arena = FlatFloor() if arena is None else arena
        super().__init__(HUMANOID3D, config, arena, build_mjcf(config, arena))
