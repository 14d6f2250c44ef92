"""Terrain generators: a height field from a kind, a difficulty in [0, 1] and a random generator.

Every kind is a profile along the clip's heading (slopes, gaps, steps; `mixed` strings them
together in 5-8 m sections) or 2-D noise (`rough`), written into a (rows = lateral, cols =
along) grid of heights in metres. Difficulty 0 is flat ground at height 0 for every kind;
difficulty 1 is SFV Fig. 8's ground: grades to 15 %, gaps to 40 cm, steps to 15 cm, bumps to
6 cm. Heights stay in [0, MAX_HEIGHT] apart from the trenches (gaps are TRENCH_DEPTH deep),
so a pelvis-height fall floor measured from 0 never fires on a hill.

Each generator also returns the *support* profile (cols,): the ground the reference's root
follows, gaps bridged and smoothed over SUPPORT_SMOOTH_M (a flat-ground clip climbs a step
over a stride, not at the riser); on rough ground the bumps' tops across the field. And, when
asked, the *footing* (rows, cols): the heights with the trenches bridged, unsmoothed, the ground a
foot's height is measured from (`actors/envs/ground.py`).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

MAX_GRADE = 0.15  # rise over run at difficulty 1 (SFV Fig. 8's 15 % slope)
MAX_GAP_M = 0.40
MAX_STEP_M = 0.15
MAX_BUMP_M = 0.06
TRENCH_DEPTH = 1.0  # m below the ground: a foot in a gap is lost, a shin on its edge is a fall
MAX_HEIGHT = 2.0  # slopes and stairs turn back down above this
FLAT_PAD_M = 1.0  # flat ground for the first metre of the clip's path (its first frame stands there)
SUPPORT_SMOOTH_M = 0.5
TERRAIN_KINDS = ("slopes", "gaps", "steps", "rough", "mixed")


@dataclass(frozen=True)
class TerrainGrid:
    """Cell centres of a height field in the terrain frame: `cols` along x from `x0`, `rows`
    across y from `y0`, `cell` metres apart."""

    x0: float
    y0: float
    cols: int
    rows: int
    cell: float

    @property
    def xs(self) -> np.ndarray:
        return self.x0 + self.cell * np.arange(self.cols)

    @property
    def ys(self) -> np.ndarray:
        return self.y0 + self.cell * np.arange(self.rows)


def check_terrain(kind: str | None, difficulty: float) -> None:
    """One-line errors, naming the flag, for a terrain name or difficulty that is not one."""
    if kind is not None and kind not in TERRAIN_KINDS:
        raise ValueError(f"--terrain must be one of {', '.join(TERRAIN_KINDS)}, got {kind!r}")
    if not 0.0 <= difficulty <= 1.0:  # NaN fails too
        raise ValueError(f"--terrain-difficulty must lie in [0, 1], got {difficulty}")


def generate(kind: str, difficulty: float, rng: np.random.Generator, grid: TerrainGrid, out: np.ndarray,
             footing: np.ndarray | None = None) -> np.ndarray:
    """Write the heights of a fresh terrain into `out` (rows, cols); return its support (cols,).
    With `footing` (rows, cols), also write the heights with the trenches bridged into it."""
    check_terrain(kind, difficulty)
    xs = grid.xs
    profile, support = np.zeros(grid.cols), np.zeros(grid.cols)
    if kind == "rough":
        out[:] = _bumps(grid, difficulty, rng)
        if footing is not None:
            footing[:] = out
        return _smooth(out.max(axis=0), grid.cell)  # the bumps' tops: a start never stands in one
    start = np.searchsorted(xs, FLAT_PAD_M)
    if kind == "mixed":
        _mixed(xs[start:], difficulty, rng, profile[start:], support[start:])
    else:
        _PROFILES[kind](xs[start:], difficulty, rng, 0.0, profile[start:], support[start:])
    out[:] = profile[None, :]
    if footing is not None:
        footing[:] = support[None, :]  # the profile, with each trench at the height of its edges
    return _smooth(support, grid.cell)


def _sections(xs: np.ndarray, rng: np.random.Generator, low: float, high: float):
    """(lo, hi) index ranges of consecutive sections of U(low, high) metres each."""
    i, n = 0, len(xs)
    while i < n:
        end = np.searchsorted(xs, xs[i] + rng.uniform(low, high))
        yield i, max(end, i + 1)
        i = max(end, i + 1)


def _turn(h: float, rng: np.random.Generator, headroom: float) -> float:
    """+1 (up) or -1 (down), at random unless `h` is within `headroom` of 0 or MAX_HEIGHT."""
    if h < headroom:
        return 1.0
    if h > MAX_HEIGHT - headroom:
        return -1.0
    return 1.0 if rng.random() < 0.5 else -1.0


def _slopes(xs, d, rng, h0, profile, support) -> float:
    """Piecewise-linear ground: 1.5-4 m sections, grades U(0.3, 1) x 15 % x d, up or down."""
    h = h0
    for lo, hi in _sections(xs, rng, 1.5, 4.0):
        grade = _turn(h, rng, 0.6) * rng.uniform(0.3, 1.0) * MAX_GRADE * d
        profile[lo:hi] = h + grade * (xs[lo:hi] - xs[lo])
        h = float(np.clip(profile[hi - 1], 0.0, MAX_HEIGHT))
        profile[lo:hi] = np.clip(profile[lo:hi], 0.0, MAX_HEIGHT)
    support[:] = profile
    return h


def _steps(xs, d, rng, h0, profile, support) -> float:
    """Flights of 2-5 steps (treads 0.4-0.8 m, rises U(0.5, 1) x 15 cm x d) between 1-2 m landings."""
    h, i, n = h0, 0, len(xs)
    while i < n:
        landing = np.searchsorted(xs, xs[i] + rng.uniform(1.0, 2.0))
        profile[i:landing] = h
        i = landing
        direction = _turn(h, rng, 5 * MAX_STEP_M)
        for _ in range(int(rng.integers(2, 6))):
            if i >= n:
                break
            h = float(np.clip(h + direction * rng.uniform(0.5, 1.0) * MAX_STEP_M * d, 0.0, MAX_HEIGHT))
            end = max(np.searchsorted(xs, xs[i] + rng.uniform(0.4, 0.8)), i + 1)
            profile[i:end] = h
            i = end
    support[:] = profile
    return h


def _gaps(xs, d, rng, h0, profile, support) -> float:
    """Ground at h0 cut by trenches U(0.5, 1) x 40 cm x d wide, 1.5-3.5 m apart.

    The field's heights are its vertices and MuJoCo joins them by triangles, so k sunk vertices
    open a gap (k + 1) cells wide at the surface: a gap of width w sinks round(w / cell) - 1
    vertices, and one narrower than 1.5 cells is not cut. Sinking ceil(w / cell) had made every
    gap of 1-10 cm (difficulty up to .25) a V-notch 20 cm wide and 1 m deep: the walk trained on
    `mixed` fell in 44 % of the episodes at difficulty .1 and its curriculum stalled there."""
    profile[:] = h0
    support[:] = h0
    cell = float(xs[1] - xs[0]) if len(xs) > 1 else 1.0
    i, n = 0, len(xs)
    while i < n:
        i = np.searchsorted(xs, xs[i] + rng.uniform(1.5, 3.5))
        if i >= n:
            break
        sunk = int(round(rng.uniform(0.5, 1.0) * MAX_GAP_M * d / cell)) - 1
        if sunk > 0:
            profile[i:i + sunk] = h0 - TRENCH_DEPTH
        i += max(sunk, 1)
    return h0


_PROFILES: dict[str, Callable] = {"slopes": _slopes, "gaps": _gaps, "steps": _steps}


def _mixed(xs, d, rng, profile, support) -> None:
    """Slopes, gaps and steps in 5-8 m sections, each starting at the height the last ended."""
    h = 0.0
    kinds = tuple(_PROFILES)
    for lo, hi in _sections(xs, rng, 5.0, 8.0):
        h = _PROFILES[kinds[int(rng.integers(len(kinds)))]](xs[lo:hi], d, rng, h, profile[lo:hi], support[lo:hi])


def _bumps(grid: TerrainGrid, d: float, rng: np.random.Generator) -> np.ndarray:
    """Smooth bumps: uniform heights on a 0.4 m lattice, bilinearly refined, in [0, 6 cm x d]."""
    step = 0.4
    coarse = rng.uniform(0.0, MAX_BUMP_M * d, (int(grid.rows * grid.cell / step) + 2, int(grid.cols * grid.cell / step) + 2))
    v = (grid.ys - grid.y0) / step
    u = (grid.xs - grid.x0) / step
    along = np.stack([np.interp(u, np.arange(coarse.shape[1]), row) for row in coarse])
    return np.stack([np.interp(v, np.arange(coarse.shape[0]), col) for col in along.T], axis=1)


def _smooth(support: np.ndarray, cell: float) -> np.ndarray:
    """A moving average over SUPPORT_SMOOTH_M, edges held."""
    k = max(1, int(round(SUPPORT_SMOOTH_M / cell)) | 1)
    padded = np.pad(support, k // 2, mode="edge")
    return np.convolve(padded, np.ones(k) / k, mode="valid")
