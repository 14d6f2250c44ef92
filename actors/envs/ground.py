"""The ground under a batch of envs on terrain: its heights, the reference lifted onto it, the heightmap.

One `Ground` per env core, over B envs' height grids (B, rows, cols) and support profiles
(B, cols) (`actors/arenas/terrain_generators.py`); a vector env's envs write rows of its
arrays (`rows(i)`), as their scene vectors do. Per episode an env draws a fresh terrain
(`regenerate`) and puts its character on it (`lift`); per step the core moves the gathered
reference up onto the support under its root (`follow`: root, centre of mass and the future
roots the policy observes, so the reward and the observation compare a clip recorded on the
flat with a character on a hill), measures the character's hands and feet from the ground
under each (`ground_end_effectors`) and writes the heightmap (`heightmap`). The flat arenas
have no `Ground` and none of this runs.

End effectors, as DeepMimic measures them on terrain (`SceneImitate::CalcRewardImitate`: the
simulated end effector's height less `mGround->SampleHeight` under it, the kinematic one's less
the kinematic character's origin height): the reward compares each foot's clearance over the
ground under it with the clip's clearance over its flat floor. Here the ground under a foot is
the *footing* (the heights with trenches bridged, so a foot stepping over a gap is measured from
its edges, not from the trench's floor 1 m down). Lifting the reference's feet by the support
under its root instead, as this code did first, put a reference foot 15 cm into a step's tread
or above it wherever the smoothed support and the tread differ, so the reward paid the policy
for dragging its feet at the height of a ramp that is not there.
"""
from __future__ import annotations

import mujoco
import numpy as np

from actors.arenas.height_lookup import HeightQuery
from actors.arenas.terrain_generators import generate

# The heightmap: heights on a grid in the character's heading frame, relative to its root's
# height. 16 points along from 0.4 m behind to 1.1 m ahead (a third of a second at the run's
# 3.5 m/s), 5 across the feet's width, 10 and 15 cm apart: 80 numbers.
HEIGHTMAP_ALONG = tuple(-0.4 + 0.1 * k for k in range(16))
HEIGHTMAP_ACROSS = (-0.3, -0.15, 0.0, 0.15, 0.3)
HEIGHTMAP_DIM = len(HEIGHTMAP_ALONG) * len(HEIGHTMAP_ACROSS)


def heightmap_points() -> np.ndarray:
    """(N, 2) heading-frame offsets of the heightmap's points, along-major."""
    along, across = np.meshgrid(HEIGHTMAP_ALONG, HEIGHTMAP_ACROSS, indexing="ij")
    return np.stack((along.ravel(), across.ravel()), axis=-1)


class Ground:
    def __init__(self, arena, heights: np.ndarray, support: np.ndarray, footing: np.ndarray):
        """`arena`: a `TerrainArena`; `heights` and `footing` (B, rows, cols) and `support` (B, cols):
        the envs' grids (views a vector env shares with its envs)."""
        self.arena = arena
        self.heights, self.support, self.footing = heights, support, footing
        b = heights.shape[0]
        grid = arena.grid
        self._xs = grid.xs
        self._offsets = heightmap_points()
        self._points = np.zeros((b, len(self._offsets), 2))
        self._map = HeightQuery(heights, arena.frame, grid, len(self._offsets))
        # The support under each reference root: one point per env, along the frame's heading.
        self._fwd = arena.frame.forward
        self._origin_along = float(np.asarray(arena.frame.origin) @ self._fwd)
        self._u = np.zeros(b)
        self._cell = np.zeros(b, dtype=np.int64)
        self._lift = np.zeros(b)
        self._pair = np.zeros((2, b))
        self._base = np.arange(b, dtype=np.int64) * grid.cols
        self._support_flat = support.reshape(-1)
        self._feet: HeightQuery | None = None  # made at the first call, for the character's end effectors

    @classmethod
    def of(cls, arena, batch: int) -> "Ground":
        g = arena.grid
        grids = np.zeros((2, batch, g.rows, g.cols), np.float32)
        return cls(arena, grids[0], np.zeros((batch, g.cols)), grids[1])

    def rows(self, i: int) -> "Ground":
        """Env i's ground as a batch of one, over views of this one's arrays."""
        return Ground(self.arena, self.heights[i:i + 1], self.support[i:i + 1], self.footing[i:i + 1])

    # ------------------------------------------------------------------ episodes
    def regenerate(self, i: int, model: mujoco.MjModel, difficulty: float, rng: np.random.Generator) -> None:
        """Env i's next terrain (the arena's kind at `difficulty`, drawn from `rng`), into `model`."""
        self.support[i] = generate(self.arena.kind, difficulty, rng, self.arena.grid, self.heights[i], self.footing[i])
        self.arena.write(model, self.heights[i])

    def support_at(self, i: int, xy) -> float:
        """The support height under world point `xy` on env i's ground."""
        along = float(np.asarray(xy, np.float64)[:2] @ self._fwd) - self._origin_along
        return float(np.interp(along, self._xs, self.support[i]))

    def lift(self, i: int, qpos: np.ndarray) -> None:
        """Raise env i's free root (qpos[:3]) by the support under it."""
        qpos[2] += self.support_at(i, qpos[:2])

    # ------------------------------------------------------------------ steps
    def follow(self, reference, roots) -> None:
        """Lift the batch's gathered reference rows (`RewardFeatures`: root and centre of mass,
        world z) and the future reference roots `roots` ((B, K, 3), None) by the support under
        each reference root. The end effectors keep the clip's heights over its flat floor
        (`ground_end_effectors` measures the character's the same way)."""
        lift = self._support_under(reference.root_pos)
        reference.root_pos[:, 2] += lift
        reference.com[:, 2] += lift
        if roots is not None:
            roots[0][..., 2] += lift[:, None]

    def ground_end_effectors(self, sim, positions: np.ndarray) -> None:
        """Make the character's end-effector heights (`RewardFeatures`, world z) heights over the
        footing under each, from their world positions `positions` (B, E, 3)."""
        if self._feet is None or self._feet.out.shape[1] != positions.shape[1]:
            self._feet = HeightQuery(self.footing, self.arena.frame, self.arena.grid, positions.shape[1])
        sim.end_effectors[..., 2] -= self._feet(positions)  # the lookup reads x, y and ignores z

    def _support_under(self, root_pos: np.ndarray) -> np.ndarray:
        """(B,) support heights under world points root_pos (B, 3): linear along the profile."""
        u, cell, lift, pair = self._u, self._cell, self._lift, self._pair
        grid = self.arena.grid
        np.matmul(root_pos[:, :2], self._fwd, out=u)
        u -= self._origin_along + grid.x0
        u /= grid.cell
        np.clip(u, 0.0, grid.cols - 1 - 1e-9, out=u)
        np.floor(u, out=lift)
        cell[:] = lift
        u -= lift
        cell += self._base
        np.take(self._support_flat, cell, out=pair[0])
        cell += 1
        np.take(self._support_flat, cell, out=pair[1])
        pair[1] -= pair[0]
        np.multiply(pair[1], u, out=lift)
        lift += pair[0]
        return lift

    def heightmap(self, root_pos: np.ndarray, yaw: np.ndarray, out: np.ndarray) -> np.ndarray:
        """The ground's heights at the heightmap's points around each root (B, 3), in its heading
        frame (`yaw`: (B, 3, 3), v_heading = v_world @ yaw), less the root's height, into `out` (B, N)."""
        points = self._points
        np.matmul(self._offsets, yaw[:, :2, :2].transpose(0, 2, 1), out=points)
        points += root_pos[:, None, :2]
        np.subtract(self._map(points), root_pos[:, 2:3], out=out)
        return out
