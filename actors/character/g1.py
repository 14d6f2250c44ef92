"""g1: the Unitree G1 (29 DoF) as a `Character` (`actors/character/base.py`).

Its numbers live in `g1_spec.py` (joints, limits, motors, PD gains, key bodies, mirror map and signs,
reward weights), its model files and MJCF in `g1_model.py` (the cached Unitree MJCF, `sfv models
fetch --robot g1`, composed with our actuators and an arena); this module gathers them behind the
interface and holds the compiled model, `G1Model` (a `CompiledCharacter`, as the humanoid's
`Humanoid`). The envs build it with `EnvConfig.character = "g1"` (`--character g1`).
"""
from __future__ import annotations

import numpy as np

from actors.arenas.flat import FlatFloor
from actors.character import g1_spec as spec
from actors.character.compiled import CompiledCharacter
from actors.character.g1_model import build_g1_mjcf
from actors.character.humanoid import PhysicsConfig


class G1:
    name = spec.NAME
    link_names = spec.LINK_NAMES
    num_links = len(spec.LINK_NAMES)
    joint_names = spec.JOINT_NAMES
    joint_is_spherical = np.zeros(spec.NUM_JOINTS, dtype=bool)
    joint_links = np.arange(1, spec.NUM_JOINTS + 1)  # link i + 1 is the child of joint i (g1.xml's chain order)
    hinge_axes = spec.HINGE_AXES
    actuator_limits = spec.JOINT_LIMITS  # the PD targets stay within the joints' range
    default_joint_pos = spec.standing_joint_angles()  # mjlab's knees-bent keyframe
    nq = spec.NQ  # 36
    nv = spec.NV  # 35
    nu = spec.NUM_JOINTS  # 29
    kp = spec.KP
    kd = spec.KD
    torque_limits = spec.EFFORT_LIMITS
    residual_scale_factors = spec.RESIDUAL_SCALE_FACTORS
    joint_limits = spec.JOINT_LIMITS
    armature = spec.ARMATURE
    end_effector_links = np.array([spec.LINK_NAMES.index(n) for n in spec.END_EFFECTORS])
    feet = spec.FEET
    fall_contact_geoms = spec.FALL_CONTACT_GEOMS
    torso_links = np.array([spec.LINK_NAMES.index(spec.ROOT_BODY), spec.LINK_NAMES.index(spec.TORSO_BODY)])  # the head is on the torso
    link_mirror = spec.LINK_MIRROR
    joint_mirror = spec.JOINT_MIRROR
    joint_mirror_sign = spec.JOINT_MIRROR_SIGN
    reward_joint_weights = spec.REWARD_JOINT_WEIGHTS

    def mjcf(self, physics: PhysicsConfig = PhysicsConfig(), arena=None) -> str:
        return build_g1_mjcf(physics, arena)

    def build(self, physics: PhysicsConfig = PhysicsConfig(), arena=None) -> G1Model:
        return G1Model(physics, arena)


G1_ROBOT = G1()


class G1Model(CompiledCharacter):
    """The compiled G1 in an arena and its index maps (`CompiledCharacter`, as the humanoid's)."""

    def __init__(self, physics: PhysicsConfig | None = None, arena=None, directory=None):
        physics = PhysicsConfig() if physics is None else physics
        arena = FlatFloor() if arena is None else arena
        super().__init__(G1_ROBOT, physics, arena, build_g1_mjcf(physics, arena, directory))
