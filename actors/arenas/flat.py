"""The arena: what the character stands in, composed with the walker into one MuJoCo model.

dm_control's split: the walker (`actors/character/humanoid.py`: bodies, joints, actuators) knows nothing
of the ground; an arena brings its assets, its world geoms and the contact pairs between them
and the walker's geoms. Contacts are explicit pairs (every geom's contype/conaffinity is 0, so
MuJoCo skips its broad phase: 7-10 % of each physics step on this model, measured), hence
anything an arena adds that should collide must list its pairs here. Scenes with boxes or
slopes are further arenas (or an arena plus props) built the same way.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FlatFloor:
    """An infinite checkered ground plane with one overhead light (DeepMimic's flat ground)."""

    geom_name: str = "floor"
    scene = None  # nothing in it moves per episode (the Arena interface, `actors/arenas/base.py`)
    terrain = None  # level ground (`actors/arenas/terrain.py` is the one that is not)
    grade = 0.0  # the ground interface the task envs read (`actors/arenas/slope.py`: the inclined plane)

    @property
    def gradient(self) -> np.ndarray:
        return np.zeros(2)

    @property
    def tilt_quat(self) -> np.ndarray:
        """(w, x, y, z) from the world's +z to the ground's normal: none."""
        return np.array([1.0, 0.0, 0.0, 0.0])

    def height_at(self, xy) -> np.ndarray:
        """The ground's height under world points `xy` (..., 2): zero everywhere."""
        return np.zeros(np.shape(xy)[:-1])

    def obstacle_geom_ids(self, model) -> tuple[int, ...]:
        """No obstacles: the ground is not one."""
        return ()

    def assets_xml(self) -> str:
        return ('<texture name="grid" type="2d" builtin="checker" width="512" height="512" rgb1="0.82 0.84 0.86" rgb2="0.68 0.7 0.73"/>\n'
                '    <material name="grid" texture="grid" texrepeat="1 1" texuniform="true"/>')

    def worldbody_xml(self) -> str:
        return ('<light pos="0 0 4" dir="0 0 -1" directional="true"/>\n'
                f'    <geom name="{self.geom_name}" type="plane" size="0 0 0.05" material="grid"/>')

    def contact_pairs_xml(self, walker_geoms: Sequence[tuple[str, str]], friction: float) -> str:
        """One pair per walker geom against the floor, the only contacts there are. Pairs do not
        inherit geom friction, so it is given here (the trajectory is bit-identical to a
        contype-filtered model). `walker_geoms`: (pair name suffix, geom name)."""
        spec = f"{friction} {friction} 0.005 0.0001 0.0001"
        return "\n    ".join(f'<pair name="{self.geom_name}_{name}" geom1="{self.geom_name}" geom2="{geom}" condim="3" friction="{spec}"/>'
                              for name, geom in walker_geoms)
