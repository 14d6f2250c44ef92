"""The box arena (actors/arenas/boxes.py): boxes collide with every link through explicit pairs,
and set_scene moves the collision geometry of the one compiled model (a standing body comes
to rest on the box at its new height, or on the floor when the box is moved away)."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

from actors.arenas.boxes import BoxArena
from actors.character.features import update_kinematics
from actors.character.humanoid import STANDING_ROOT_HEIGHT
from actors.character.humanoid3d import Humanoid
from actors.arenas.scene import Box, Scene
from actors.character.skeleton import LINK_NAMES, LINKS

SCENE = Scene((Box("step", along=0.0, height=0.2, size=(0.8, 0.8)),))
ANKLES = [LINK_NAMES.index("right_ankle"), LINK_NAMES.index("left_ankle")]
ANKLE_ABOVE_SOLE = 0.05


@pytest.fixture(scope="module")
def humanoid():
    return Humanoid(arena=BoxArena(SCENE))


def _stand(humanoid, drop_from: float, seconds: float = 0.6):
    """Stand the character with its soles `drop_from` m above the floor, hold its pose with
    the PD servos, and return the ankles' heights and the geoms it touches at the end."""
    model = humanoid.model
    data = mujoco.MjData(model)
    data.qpos[2] = STANDING_ROOT_HEIGHT + drop_from
    data.qpos[3] = 1.0
    update_kinematics(model, data)
    mujoco.mj_transmission(model, data)
    data.ctrl[:] = data.actuator_length
    mujoco.mj_step(model, data, nstep=int(seconds / model.opt.timestep))
    mujoco.mj_forward(model, data)
    touched = {int(g) for pair in data.contact.geom[:data.ncon] for g in pair}
    return data.xpos[humanoid.body_ids[ANKLES], 2], touched


def test_every_link_has_a_pair_with_each_box(humanoid):
    model = humanoid.model
    (box,) = humanoid.arena.box_geom_ids(model)
    partners = {int(model.pair_geom2[i]) for i in range(model.npair) if model.pair_geom1[i] == box}
    links = {mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, f"{link.name}_geom") for link in LINKS}
    assert partners == links


def test_set_scene_moves_the_collision_geometry_of_the_compiled_model(humanoid):
    model, arena = humanoid.model, humanoid.arena
    (box,) = arena.box_geom_ids(model)
    floor = humanoid.floor_geom_id
    for height in (0.1, 0.35):
        arena.set_scene(model, [0.0, height])
        ankles, touched = _stand(humanoid, drop_from=height + 0.05)
        np.testing.assert_allclose(ankles, height + ANKLE_ABOVE_SOLE, atol=0.02)
        assert box in touched and floor not in touched
    arena.set_scene(model, [3.0, 0.35])  # moved away along the heading: the floor holds the body
    ankles, touched = _stand(humanoid, drop_from=0.05)
    np.testing.assert_allclose(ankles, ANKLE_ABOVE_SOLE, atol=0.02)
    assert floor in touched and box not in touched
    arena.set_scene(model, SCENE.vector())
