"""An infinite inclined plane: the ground of SFV Fig. 8's push up and down a 15 % slope.

The plane rises along world +x by `grade` (rise over run; 0.15 is the paper's 15 %, 8.5
degrees) and passes through the origin, so the ground's height under (x, y) is grade * x. It
is one MuJoCo plane geom turned about the y axis: exact contacts at the cost of the flat floor
(a height field of the same slope would cost its cells, `actors/arenas/terrain.py`). The slope
is fixed in the world; the task envs turn their starts instead (`actors/envs/tasks/slope_starts.py`),
so a push goes up, down or across it by the character's heading. `FlatFloor` is the grade-0 case
of the same ground interface (`height_at`, `gradient`).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from actors.arenas.flat import FlatFloor


@dataclass(frozen=True)
class SlopeFloor:
    """A checkered plane whose height is `grade` * x (grade > 0: uphill along +x)."""

    grade: float = 0.15
    geom_name: str = "floor"
    scene = None  # nothing in it moves per episode
    terrain = None  # no height field: the plane is the whole ground

    def __post_init__(self):
        if not (math.isfinite(self.grade) and 0.0 <= self.grade <= 1.0):
            raise ValueError(f"--slope must lie in [0, 1] (rise over run), got {self.grade}")

    @property
    def angle(self) -> float:
        """The plane's inclination (radians)."""
        return math.atan(self.grade)

    @property
    def tilt_quat(self) -> np.ndarray:
        """(w, x, y, z) turning the world's +z onto the plane's normal (-sin a, 0, cos a)."""
        half = -self.angle / 2
        return np.array([math.cos(half), 0.0, math.sin(half), 0.0])

    @property
    def gradient(self) -> np.ndarray:
        """d height / d (x, y) in the world."""
        return np.array([self.grade, 0.0])

    def height_at(self, xy) -> np.ndarray:
        """The ground's height under world points `xy` (..., 2)."""
        return self.grade * np.asarray(xy, np.float64)[..., 0]

    def obstacle_geom_ids(self, model) -> tuple[int, ...]:
        return ()

    def assets_xml(self) -> str:
        return FlatFloor(self.geom_name).assets_xml()

    def worldbody_xml(self) -> str:
        w, x, y, z = self.tilt_quat
        return ('<light pos="0 0 4" dir="0 0 -1" directional="true"/>\n'
                f'    <geom name="{self.geom_name}" type="plane" size="0 0 0.05" material="grid" quat="{w:.10g} {x:.10g} {y:.10g} {z:.10g}"/>')

    def contact_pairs_xml(self, walker_geoms: Sequence[tuple[str, str]], friction: float) -> str:
        return FlatFloor(self.geom_name).contact_pairs_xml(walker_geoms, friction)


def task_floor(grade: float) -> FlatFloor | SlopeFloor:
    """The ground of a task env: the flat floor at grade 0 (bit-identical models), else the slope."""
    return FlatFloor() if grade == 0.0 else SlopeFloor(grade)
