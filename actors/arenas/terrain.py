"""Terrain: one MuJoCo height field along the clip's path, an `Arena` registered as "terrain".

Slopes, gaps (trenches TRENCH_DEPTH deep), steps, rough ground and their mix are all one
`hfield` geom (`actors/arenas/terrain_generators.py` writes its heights), so there is one
ground geom for the fall rule and the feet, one list of contact pairs, and a height query is
a lookup into the grid (`actors/arenas/height_lookup.py`). The field covers the clip's root
path over the episode horizon (cycles of a looped clip laid end to end) plus margins, in the
frame of the clip's first frame (`SceneFrame`), CELL_M apart. The compiled model's field is a template; every env owns a copy of the
model and writes fresh heights into it per episode (`write(model, heights)`), never recompiling.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from actors.arenas.scene import SceneFrame
from actors.arenas.terrain_generators import MAX_HEIGHT, TERRAIN_KINDS, TRENCH_DEPTH, TerrainGrid, check_terrain

# The field's spacing: MuJoCo collides a geom with every cell under it, two prisms a cell. Physics
# per control step (walk, 300 Hz, one env, nice'd): 0.30 ms on the plane, 0.49 ms on a 10 cm field,
# 0.84 ms on a 5 cm one (12 contacts standing against 6); 10 cm halves the field's cost, and a
# 15 cm step is then a 56 degree ramp one cell long.
CELL_M = 0.10
BACK_MARGIN_M = 3.0
FRONT_MARGIN_M = 5.0
SIDE_MARGIN_M = 4.0
Z_LOW = -TRENCH_DEPTH  # the field's zero; heights are stored as (h - Z_LOW) / Z_RANGE in [0, 1]
Z_RANGE = MAX_HEIGHT + TRENCH_DEPTH
BASE_M = 0.5  # the field's slab below Z_LOW
HFIELD_NAME = "terrain"


@dataclass(frozen=True)
class TerrainArena:
    """A height field of `kind` along `frame`'s heading over `grid` (heights set per episode)."""

    kind: str
    frame: SceneFrame
    grid: TerrainGrid
    geom_name: str = "floor"  # the ground geom, as the flat floor's (the fall rule reads it)
    scene = None  # no boxes

    @property
    def terrain(self) -> "TerrainArena":
        """The Arena seam's handle on a ground that is not level (None on the other arenas)."""
        return self

    @classmethod
    def along(cls, kind: str, motion, horizon_s: float, cell: float = CELL_M) -> "TerrainArena":
        """The field under `motion`'s root path over `horizon_s` seconds, in its first frame's frame."""
        check_terrain(kind, 0.0)
        frame = SceneFrame.of_motion(motion)
        cycles = math.ceil(horizon_s / max(motion.duration, 1e-6)) + 1 if motion.loop else 1
        path = (motion.root_pos[None, :, :2] + np.arange(cycles)[:, None, None] * motion.cycle_offset[:2]).reshape(-1, 2)
        local = frame.to_scene(path)
        x0 = float(local[:, 0].min()) - BACK_MARGIN_M
        width = 2 * (float(np.abs(local[:, 1]).max()) + SIDE_MARGIN_M)
        cols = int(math.ceil((float(local[:, 0].max()) + FRONT_MARGIN_M - x0) / cell)) + 1
        rows = int(math.ceil(width / cell)) + 1
        return cls(kind, frame, TerrainGrid(x0, -cell * (rows - 1) / 2, cols, rows, cell))

    # ------------------------------------------------------------------ the Arena
    def assets_xml(self) -> str:
        g = self.grid
        half = (g.cell * (g.cols - 1) / 2, g.cell * (g.rows - 1) / 2)
        return ('<texture name="grid" type="2d" builtin="checker" width="512" height="512" rgb1="0.82 0.84 0.86" rgb2="0.68 0.7 0.73"/>\n'
                '    <material name="grid" texture="grid" texrepeat="4 4" texuniform="true"/>\n'
                f'    <hfield name="{HFIELD_NAME}" nrow="{g.rows}" ncol="{g.cols}" size="{half[0]:.8g} {half[1]:.8g} {Z_RANGE:.8g} {BASE_M:.8g}"/>')

    def worldbody_xml(self) -> str:
        g = self.grid
        centre = self.frame.to_world(g.x0 + g.cell * (g.cols - 1) / 2, g.y0 + g.cell * (g.rows - 1) / 2)
        yaw = self.frame.yaw
        return ('<light pos="0 0 4" dir="0 0 -1" directional="true"/>\n'
                f'    <geom name="{self.geom_name}" type="hfield" hfield="{HFIELD_NAME}" material="grid" '
                f'pos="{centre[0]:.8g} {centre[1]:.8g} {Z_LOW:.8g}" quat="{math.cos(yaw / 2):.8g} 0 0 {math.sin(yaw / 2):.8g}"/>')

    def contact_pairs_xml(self, walker_geoms: Sequence[tuple[str, str]], friction: float) -> str:
        spec = f"{friction} {friction} 0.005 0.0001 0.0001"
        return "\n    ".join(f'<pair name="{self.geom_name}_{name}" geom1="{self.geom_name}" geom2="{geom}" condim="3" friction="{spec}"/>'
                              for name, geom in walker_geoms)

    def obstacle_geom_ids(self, model) -> tuple[int, ...]:
        return ()

    # ------------------------------------------------------------------ runtime
    def write(self, model: mujoco.MjModel, heights: np.ndarray) -> None:
        """Put `heights` (rows, cols, metres) into this arena's field of `model` (an env's copy)."""
        hfield = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_HFIELD, HFIELD_NAME)
        adr, n = model.hfield_adr[hfield], self.grid.rows * self.grid.cols
        np.clip((heights.reshape(-1) - Z_LOW) / Z_RANGE, 0.0, 1.0, out=model.hfield_data[adr:adr + n])


def terrain_arena(kind: str, motion, horizon_s: float) -> TerrainArena:
    """The registry's factory (`make_arena("terrain", kind=..., motion=..., horizon_s=...)`)."""
    return TerrainArena.along(kind, motion, horizon_s)


__all__ = ["TERRAIN_KINDS", "TerrainArena", "terrain_arena"]
