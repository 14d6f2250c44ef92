"""humanoid3d: DeepMimic's humanoid (SFV's character) as a `Character` (`actors/character/base.py`).

Its numbers live in `skeleton.py` (links, joints, gains, masses, left/right partners, reward
weights), its MJCF in `humanoid.py`; this module gathers them behind the interface and holds
the compiled model, `Humanoid`, which carries its description as `character`.
"""
from __future__ import annotations

import mujoco
import numpy as np

from actors.arenas.flat import FlatFloor
from actors.character import skeleton
from actors.character.humanoid import PhysicsConfig, build_mjcf
from actors.character.skeleton import FALL_CONTACT_LINKS, JOINT_LINKS, LINKS


class Humanoid3D:
    name = "humanoid3d"
    link_names = skeleton.LINK_NAMES
    num_links = skeleton.NUM_LINKS
    joint_names = skeleton.JOINT_NAMES
    joint_is_spherical = skeleton.JOINT_IS_SPHERICAL
    nu = skeleton.NUM_ACTUATED_DOF  # 28
    nq = 7 + 4 * int(skeleton.JOINT_IS_SPHERICAL.sum()) + int((~skeleton.JOINT_IS_SPHERICAL).sum())  # 43
    nv = 6 + nu  # 34
    hinge_axes = np.tile(skeleton.HINGE_AXIS, (int((~skeleton.JOINT_IS_SPHERICAL).sum()), 1))  # every hinge turns about one axis
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


class Humanoid:
    """The compiled humanoid3d (its MJCF from `humanoid.py`, in an arena) and the index maps
    between skeleton order and MuJoCo order; `character` is the description it was built from
    (what features, actions and mirror maps read)."""

    def __init__(self, config: PhysicsConfig = PhysicsConfig(), arena=None):
        self.character = HUMANOID3D
        self.config = config
        self.arena = FlatFloor() if arena is None else arena
        self.model = mujoco.MjModel.from_xml_string(build_mjcf(config, self.arena))
        m = self.model
        self.body_ids = np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, link.name) for link in LINKS])
        joint_ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, LINKS[i].name) for i in JOINT_LINKS]
        self.joint_qpos_adr = m.jnt_qposadr[joint_ids].copy()
        self.joint_dof_adr = m.jnt_dofadr[joint_ids].copy()
        # Torso and head geoms (the facts file's flag); episodes use the per-clip rule of actors/envs/falls.py.
        self.fall_geom_ids = np.array([m.body_geomadr[self.body_ids[i]] for i in FALL_CONTACT_LINKS])
        # MuJoCo numbers bodies depth-first, so the 15 links are bodies 1..15 (a contiguous
        # slice of xpos / xquat / cvel) in an order other than the skeleton's.
        assert sorted(self.body_ids) == list(range(1, len(LINKS) + 1))
        self.floor_geom_id = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, self.arena.geom_name)
        self.num_actuators = m.nu

    @property
    def nq(self) -> int:
        return self.model.nq

    @property
    def nv(self) -> int:
        return self.model.nv
