"""The arena composed with the walker: the floor's pairs cover every link, and another arena
changes the scene without touching the humanoid's bodies."""
from __future__ import annotations

import mujoco

from actors.arenas.flat import FlatFloor
from actors.character.humanoid import PhysicsConfig
from actors.character.humanoid3d import Humanoid
from actors.character.skeleton import LINKS


def _pairs(model):
    return {(model.pair_geom1[i], model.pair_geom2[i]) for i in range(model.npair)}


def test_flat_floor_pairs_every_link_geom_with_the_floor():
    humanoid = Humanoid()
    model = humanoid.model
    floor = humanoid.floor_geom_id
    link_geoms = {mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, f"{link.name}_geom") for link in LINKS}
    assert _pairs(model) == {(floor, g) for g in link_geoms}
    assert all(model.pair_friction[i][0] == PhysicsConfig().friction for i in range(model.npair))


def test_an_arena_with_another_floor_name_keeps_the_walker_and_renames_its_pairs():
    default, other = Humanoid(), Humanoid(arena=FlatFloor(geom_name="ground"))
    assert other.model.nbody == default.model.nbody and other.model.nu == default.model.nu
    ground = mujoco.mj_name2id(other.model, mujoco.mjtObj.mjOBJ_GEOM, "ground")
    assert other.floor_geom_id == ground >= 0 and mujoco.mj_name2id(other.model, mujoco.mjtObj.mjOBJ_GEOM, "floor") == -1
    names = {mujoco.mj_id2name(other.model, mujoco.mjtObj.mjOBJ_PAIR, i) for i in range(other.model.npair)}
    assert names == {f"ground_{link.name}" for link in LINKS}
