"""Terrain generators and the height field: seeds repeat, difficulty 0 is flat, difficulty 1 is
SFV Fig. 8's ground, and the lookup reads the heights MuJoCo collides with."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

from actors.arenas.height_lookup import HeightQuery
from actors.arenas.scene import SceneFrame
from actors.arenas.terrain import TerrainArena
from actors.arenas.terrain_generators import (MAX_GAP_M, MAX_GRADE, MAX_STEP_M, TERRAIN_KINDS, TRENCH_DEPTH, TerrainGrid,
                                              check_terrain, generate)
from actors.character.humanoid import PhysicsConfig
from actors.character.humanoid3d import Humanoid

GRID = TerrainGrid(x0=-3.0, y0=-2.0, cols=700, rows=81, cell=0.05)


def _draw(kind, difficulty, seed):
    heights = np.zeros((GRID.rows, GRID.cols))
    support = generate(kind, difficulty, np.random.default_rng(seed), GRID, heights)
    return heights, support


@pytest.mark.parametrize("kind", TERRAIN_KINDS)
def test_a_seed_gives_the_same_terrain_and_another_seed_another(kind):
    first, again, other = _draw(kind, 1.0, 7), _draw(kind, 1.0, 7), _draw(kind, 1.0, 8)
    assert np.array_equal(first[0], again[0]) and np.array_equal(first[1], again[1])
    assert not np.array_equal(first[0], other[0])


@pytest.mark.parametrize("kind", TERRAIN_KINDS)
def test_difficulty_zero_is_flat(kind):
    heights, support = _draw(kind, 0.0, 3)
    assert np.all(heights == 0.0) and np.all(support == 0.0)


def _profile(kind):
    heights, _ = _draw(kind, 1.0, 11)
    assert np.all(heights == heights[:1])  # a profile along the heading: the same on every row
    return heights[0]


def test_slopes_at_difficulty_one_reach_but_never_pass_fifteen_percent():
    grades = np.abs(np.diff(_profile("slopes"))) / GRID.cell
    assert grades.max() <= MAX_GRADE + 1e-9 and grades.max() > 0.8 * MAX_GRADE


def test_steps_at_difficulty_one_rise_up_to_fifteen_centimetres():
    rises = np.abs(np.diff(_profile("steps")))
    rises = rises[rises > 1e-9]
    assert rises.max() <= MAX_STEP_M + 1e-9 and rises.max() > 0.1 and len(rises) >= 10


def _gap_openings(grid, difficulty, seed=11):
    """Each trench's width at the surface: k sunk vertices open k + 1 cells (MuJoCo's triangles)."""
    heights = np.zeros((grid.rows, grid.cols))
    generate("gaps", difficulty, np.random.default_rng(seed), grid, heights)
    down = heights[0] < -0.5 * TRENCH_DEPTH
    edges = np.flatnonzero(np.diff(down.astype(int)))
    return (edges[1::2] - edges[0::2] + 1) * grid.cell


def test_gaps_at_difficulty_one_are_trenches_up_to_forty_centimetres():
    widths = _gap_openings(GRID, 1.0)
    assert len(widths) >= 5 and widths.max() <= MAX_GAP_M + GRID.cell / 2 + 1e-9 and widths.max() > 0.3


@pytest.mark.parametrize("cell", [0.05, 0.1])
def test_a_gap_narrower_than_a_cell_and_a_half_is_not_cut(cell):
    """On the training field's 10 cm cells, gaps of difficulty .1 (2-4 cm) had become 20 cm V-notches 1 m deep."""
    grid = TerrainGrid(x0=-3.0, y0=-2.0, cols=int(35 / cell), rows=5, cell=cell)
    narrow = 0.9 * 1.5 * cell / MAX_GAP_M  # the widest gap drawn is 0.9 x 1.5 cells
    assert len(_gap_openings(grid, narrow)) == 0
    widths = _gap_openings(grid, 1.0)
    assert len(widths) >= 5 and widths.min() >= 2 * cell - 1e-9 and widths.max() <= MAX_GAP_M + cell / 2 + 1e-9


def test_the_first_metre_of_the_path_stays_flat_for_the_first_frame():
    for kind in ("slopes", "gaps", "steps", "mixed"):
        heights, _ = _draw(kind, 1.0, 5)
        assert np.all(heights[:, GRID.xs < 1.0] == 0.0)


def test_bad_terrain_name_or_difficulty_is_one_line_naming_the_flag():
    with pytest.raises(ValueError, match=r"^--terrain must be one of slopes, gaps, steps, rough, mixed, got 'stairs'$"):
        check_terrain("stairs", 0.5)
    for bad in (-0.1, 1.5, float("nan")):
        with pytest.raises(ValueError, match=r"^--terrain-difficulty must lie in \[0, 1\]"):
            check_terrain("mixed", bad)


def test_the_lookup_reads_the_heights_mujoco_collides_with():
    """Rays cast down onto the compiled field land where the bilinear lookup says, in a frame
    turned off the world's axes (vertices and planar cells exactly; a cell that is not planar
    within its height difference)."""
    frame = SceneFrame(origin=(1.0, -2.0), yaw=0.7)
    arena = TerrainArena("mixed", frame, TerrainGrid(-3.0, -2.0, 200, 41, 0.1))
    model = Humanoid(arena=arena).model
    heights = np.zeros((1, arena.grid.rows, arena.grid.cols), np.float32)
    generate("mixed", 1.0, np.random.default_rng(2), arena.grid, heights[0])
    arena.write(model, heights[0])
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    rng = np.random.default_rng(0)
    local = np.stack((rng.uniform(-2.5, 16.0, 200), rng.uniform(-1.5, 1.5, 200)), axis=-1)
    world = frame.to_world(local[:, 0], local[:, 1])
    geom = np.zeros(1, np.int32)
    rays = np.array([5.0 - mujoco.mj_ray(model, data, np.array([x, y, 5.0]), np.array([0.0, 0.0, -1.0]), None, 1, -1, geom)
                     for x, y in world])
    looked_up = HeightQuery(heights, frame, arena.grid, len(world))(world[None])[0]
    riser = np.abs(np.diff(heights[0], axis=1)).max()
    assert np.median(np.abs(looked_up - rays)) < 1e-5 and np.abs(looked_up - rays).max() <= riser
    assert heights.max() - heights.min() > 0.5  # a terrain, not a floor
