"""humanoid3d: DeepMimic's humanoid (SFV's character) as a `Character` (`actors/character/base.py`).

Its numbers live in `skeleton.py` (links, joints, gains, masses, left/right partners, reward
weights), its model in `humanoid.py` (the MJCF and the compiled `Humanoid`); this module
gathers them behind the interface.
"""
from __future__ import annotations

import numpy as np

from actors.character import skeleton
from actors.character.humanoid import Humanoid, PhysicsConfig, build_mjcf


class Humanoid3D:
    name = "humanoid3d"
    link_names = skeleton.LINK_NAMES
    num_links = skeleton.NUM_LINKS
    joint_names = skeleton.JOINT_NAMES
    joint_is_spherical = skeleton.JOINT_IS_SPHERICAL
    nu = skeleton.NUM_ACTUATED_DOF  # 28
    nq = 7 + 4 * int(skeleton.JOINT_IS_SPHERICAL.sum()) + int((~skeleton.JOINT_IS_SPHERICAL).sum())  # 43
    nv = 6 + nu  # 34
    hinge_axis = skeleton.HINGE_AXIS
    actuator_limits = skeleton.actuator_limits()
    kp = np.array([skeleton.LINKS[i].kp for i in skeleton.JOINT_LINKS])
    kd = np.array([skeleton.LINKS[i].kd for i in skeleton.JOINT_LINKS])
    torque_limits = np.array([skeleton.LINKS[i].torque_limit for i in skeleton.JOINT_LINKS])
    end_effector_links = skeleton.END_EFFECTOR_LINKS
    feet = ("right_ankle", "left_ankle")
    torso_links = skeleton.FALL_CONTACT_LINKS
    link_mirror = skeleton.LINK_MIRROR
    joint_mirror = skeleton.JOINT_MIRROR
    reward_joint_weights = skeleton.DEEPMIMIC_JOINT_WEIGHTS

    def mjcf(self, physics: PhysicsConfig = PhysicsConfig(), arena=None) -> str:
        return build_mjcf(physics, arena)

    def build(self, physics: PhysicsConfig = PhysicsConfig(), arena=None) -> Humanoid:
        return Humanoid(physics, arena)


HUMANOID3D = Humanoid3D()
