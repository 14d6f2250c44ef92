"""Batched ground-height queries: bilinear lookup into each env's height grid.

B envs each own a (rows, cols) grid of heights (one (B, rows, cols) array); a query of N
world points per env (B, N, 2) is a few vectorised numpy operations into buffers made once
for that N: no Python loop over envs or cells. Bilinear interpolation equals MuJoCo's
triangulated field at the vertices and on planar cells (slopes, treads); it differs inside a
cell that is not planar (a riser's cell, a bump), by under the cell's height difference.
"""
from __future__ import annotations

import numpy as np

from actors.arenas.scene import SceneFrame
from actors.arenas.terrain_generators import TerrainGrid


class HeightQuery:
    """Heights of N world points per env in the envs' grids `heights` (B, rows, cols, contiguous)."""

    def __init__(self, heights: np.ndarray, frame: SceneFrame, grid: TerrainGrid, points: int):
        b, rows, cols = heights.shape
        if not heights.flags.c_contiguous:
            raise ValueError("internal: height grids must be one contiguous (B, rows, cols) array")
        self._flat = heights.reshape(-1)
        self._cols = cols
        self._hi = (cols - 1 - 1e-9, rows - 1 - 1e-9)
        # Grid coordinates (u along, v across, in cells) as affine maps of world x, y.
        fwd, left, o = frame.forward, frame.left, np.asarray(frame.origin)
        self._u = (fwd[0] / grid.cell, fwd[1] / grid.cell, (-o @ fwd - grid.x0) / grid.cell)
        self._v = (left[0] / grid.cell, left[1] / grid.cell, (-o @ left - grid.y0) / grid.cell)
        self._base = (np.arange(b, dtype=np.int64) * rows * cols)[:, None]
        shape = (b, points)
        self._uv = np.zeros((2, *shape))
        self._cell = np.zeros((2, *shape), dtype=np.int64)
        self._index = np.zeros(shape, dtype=np.int64)
        self._corner = np.zeros((4, *shape), dtype=heights.dtype)
        self.out = np.zeros(shape)

    def __call__(self, xy: np.ndarray) -> np.ndarray:
        """(B, N) heights at world points `xy` (B, N, 2); points off the grid take its edge's."""
        uv, cell, index, corner, out = self._uv, self._cell, self._index, self._corner, self.out
        x, y = xy[..., 0], xy[..., 1]
        for k, (a, b, c) in enumerate((self._u, self._v)):
            np.multiply(x, a, out=uv[k])
            np.multiply(y, b, out=out)
            uv[k] += out
            uv[k] += c
            np.clip(uv[k], 0.0, self._hi[k], out=uv[k])
            np.floor(uv[k], out=out)
            cell[k] = out
            uv[k] -= out  # now the fraction within the cell
        np.multiply(cell[1], self._cols, out=index)
        index += cell[0]
        index += self._base
        flat, cols = self._flat, self._cols
        np.take(flat, index, out=corner[0])
        index += 1
        np.take(flat, index, out=corner[1])
        index += cols
        np.take(flat, index, out=corner[3])
        index -= 1
        np.take(flat, index, out=corner[2])
        # Along u on the near and far rows, then across v.
        corner[1] -= corner[0]
        corner[3] -= corner[2]
        fu, fv = uv
        np.multiply(corner[1], fu, out=out)
        corner[0] += out
        np.multiply(corner[3], fu, out=out)
        corner[2] += out
        corner[2] -= corner[0]
        np.multiply(corner[2], fv, out=out)
        out += corner[0]
        return out
