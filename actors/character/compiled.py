"""A character compiled in an arena: the MuJoCo model and its index maps, for any body.

Each `Character` builds one of these (`build(physics, arena)`) from its own MJCF text; what
the env reads of it is the same for every body: the character description it came from
(`character`), the model, the MuJoCo ids of its links (`body_ids`, link order), each joint's
first qpos / DoF address (`joint_qpos_adr`, `joint_dof_adr`, joint order), its torso and head
geoms, the arena's floor geom and the sizes `nq`, `nv`, `num_actuators`.
"""
from __future__ import annotations

import mujoco
import numpy as np


def _ids(model: mujoco.MjModel, kind: mujoco.mjtObj, names) -> np.ndarray:
    ids = np.array([mujoco.mj_name2id(model, kind, name) for name in names], dtype=np.int64)
    if (ids < 0).any():
        missing = [name for name, i in zip(names, ids) if i < 0]
        raise ValueError(f"internal: the compiled model has no {kind.name.removeprefix('mjOBJ_').lower()} {missing[0]}")
    return ids


class CompiledCharacter:
    def __init__(self, character, physics, arena, mjcf: str):
        self.character = character
        self.config = physics
        self.arena = arena
        self.model = mujoco.MjModel.from_xml_string(mjcf)
        m = self.model
        self.body_ids = _ids(m, mujoco.mjtObj.mjOBJ_BODY, character.link_names)
        joint_ids = _ids(m, mujoco.mjtObj.mjOBJ_JOINT, character.joint_names)
        self.joint_qpos_adr = m.jnt_qposadr[joint_ids].copy()
        self.joint_dof_adr = m.jnt_dofadr[joint_ids].copy()
        # Torso and head (the facts file's flag); episodes use the per-clip rule of actors/envs/falls.py.
        self.fall_geom_ids = _ids(m, mujoco.mjtObj.mjOBJ_GEOM, character.fall_contact_geoms)
        # Features read the links as bodies 1..num_links (a contiguous slice of xpos / xquat /
        # cvel; MuJoCo numbers bodies depth-first, the link order may differ), an arena's props after them.
        assert sorted(self.body_ids.tolist()) == list(range(1, character.num_links + 1))
        self.floor_geom_id = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, self.arena.geom_name)
        self.num_actuators = m.nu

    @property
    def nq(self) -> int:
        return self.model.nq

    @property
    def nv(self) -> int:
        return self.model.nv
