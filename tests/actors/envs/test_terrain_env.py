"""The env on terrain: the heightmap reads a known step in the heading frame, starts stand on
the ground under them, the reference follows it, and a vector env's curriculum and log."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

from actors.arenas.scene import SceneFrame
from actors.arenas.terrain import TerrainArena
from actors.arenas.terrain_generators import TerrainGrid
from actors.envs.ground import HEIGHTMAP_ALONG, HEIGHTMAP_ACROSS, HEIGHTMAP_DIM, Ground
from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.envs.initial_states import BufferedStarts, ReferenceStarts
from actors.envs.terrain_curriculum import LEVELS, TerrainCurriculum
from actors.envs.vector_env import VectorImitationEnv
from actors.motion.formats.io import load_motion

STEP_X, STEP_H = 1.0, 0.15


@pytest.fixture(scope="module")
def walk():
    return load_motion("deepmimic:walk")


def _step_ground(batch: int) -> Ground:
    """A 15 cm step up at world x = 1 m, everywhere across."""
    arena = TerrainArena("steps", SceneFrame(), TerrainGrid(-3.0, -2.0, 201, 81, 0.05))
    ground = Ground.of(arena, batch)
    ground.heights[:, :, arena.grid.xs >= STEP_X] = STEP_H
    return ground


def _heading(yaws):
    m = np.zeros((len(yaws), 3, 3))
    c, s = np.cos(yaws), np.sin(yaws)
    m[:, 0, 0], m[:, 0, 1], m[:, 1, 0], m[:, 1, 1], m[:, 2, 2] = c, -s, s, c, 1.0
    return m


def test_the_heightmap_sees_a_step_ahead_facing_it_and_behind_facing_away():
    ground = _step_ground(2)
    roots = np.array([[0.5, 0.0, 0.9], [0.8, 0.3, 0.8]])
    out = np.zeros((2, HEIGHTMAP_DIM))
    ground.heightmap(roots, _heading(np.array([0.0, np.pi])), out)
    along = np.repeat(HEIGHTMAP_ALONG, len(HEIGHTMAP_ACROSS))
    cell = ground.arena.grid.cell
    facing, away = out[0] + 0.9, out[1] + 0.8  # ground heights
    for h, x in ((facing, 0.5 + along), (away, 0.8 - along)):  # world x of each point
        clear = np.abs(x - STEP_X) > cell  # not on the riser's cell
        assert np.allclose(h[clear], np.where(x[clear] >= STEP_X, STEP_H, 0.0), atol=1e-6)
    assert facing[along > 0.6].min() == pytest.approx(STEP_H, abs=1e-6) and facing[along < 0.4].max() == 0.0
    assert away[along < -0.25].min() == pytest.approx(STEP_H, abs=1e-6) and away[along > 0].max() == 0.0


def test_the_reference_follows_the_support_under_its_root():
    ground = _step_ground(1)
    ground.support[0] = np.where(ground.arena.grid.xs >= STEP_X, STEP_H, 0.0)

    class Ref:
        root_pos = np.array([[0.2, 0.0, 0.9]])
        com = np.array([[0.2, 0.0, 0.8]])
        end_effectors = np.zeros((1, 4, 3))

    before, beyond = Ref(), Ref()
    beyond.root_pos = np.array([[1.6, 0.0, 0.9]])
    roots = (np.zeros((1, 2, 3)), None)
    ground.follow(before, None)
    ground.follow(beyond, roots)
    assert before.root_pos[0, 2] == pytest.approx(0.9) and beyond.root_pos[0, 2] == pytest.approx(0.9 + STEP_H)
    assert beyond.com[0, 2] == pytest.approx(0.8 + STEP_H) and np.allclose(roots[0][..., 2], STEP_H)


def test_feet_are_measured_from_the_ground_under_each_and_a_gap_from_its_edges():
    """DeepMimic's end-effector heights on terrain: over the ground under each foot, so a foot
    on a step's tread in the clip's pose matches the clip's foot on its flat floor."""
    ground = _step_ground(1)
    xs = ground.arena.grid.xs
    gap = (xs > 2.0) & (xs < 2.3)
    ground.heights[:, :, gap] -= 1.0  # a trench in the tread beyond the step
    ground.footing[:] = np.where(xs >= STEP_X, STEP_H, 0.0)  # bridged: the tread's height across the trench

    class Sim:
        end_effectors = np.zeros((1, 4, 3))

    clearance = np.array([0.02, 0.10, 0.0, 0.3])
    world = np.array([[[0.5, 0.1, 0.0], [1.5, -0.1, 0.0], [2.15, 0.1, 0.0], [2.6, 0.0, 0.0]]])
    world[0, :, 2] = clearance + np.where(world[0, :, 0] >= STEP_X, STEP_H, 0.0)
    sim = Sim()
    sim.end_effectors[..., 2] = world[..., 2]
    ground.ground_end_effectors(sim, world)
    assert np.allclose(sim.end_effectors[0, :, 2], clearance, atol=1e-6)


def test_a_stepping_env_rewards_the_feet_heights_over_the_footing_under_them(walk, monkeypatch):
    """The core's reward sees each foot's height over the footing under it (steps: a profile
    along the terrain frame's x), read here by an independent interpolation."""
    monkeypatch.setattr("actors.arenas.terrain_generators.FLAT_PAD_M", -3.0)  # steps under the start too
    starts = BufferedStarts(ReferenceStarts("rsi", np.random.default_rng(0)), batch=4)
    env = VectorImitationEnv(walk, EnvConfig(terrain="steps", terrain_difficulty=1.0, terrain_curriculum=False), 1, starts, seed=0)
    env.reset()
    core, ground = env.core, env.core.ground
    frame, xs = ground.arena.frame, ground.arena.grid.xs
    for _ in range(20):
        env.step(np.zeros((1, env.action_dim), np.float32))
    feet = core.features.end_effector_positions()[0]
    along = (feet[:, :2] - np.asarray(frame.origin)[:2]) @ np.asarray(frame.forward)[:2]
    under = np.interp(along, xs, ground.footing[0, ground.footing.shape[1] // 2])
    assert np.abs(under).max() > 0.05  # the feet stand over steps, not the flat
    assert np.allclose(core.features.sim.end_effectors[0, :, 2], feet[:, 2] - under, atol=1e-5)


def _lowest_foot_clearance(env):
    """Height of the lowest point of the walker's geoms over the ground under it (mj_ray down)."""
    model, data = env.model, env.data
    floor = env.humanoid.floor_geom_id
    low = min(range(model.ngeom), key=lambda g: data.geom_xpos[g, 2] if g != floor else np.inf)
    p = data.geom_xpos[low].copy()
    geom = np.zeros(1, np.int32)
    below = mujoco.mj_ray(model, data, p + [0, 0, 3.0], np.array([0.0, 0.0, -1.0]), None, 1, -1, geom)
    return 3.0 - below


def test_starts_stand_on_the_slope_under_them(walk, monkeypatch):
    monkeypatch.setattr("actors.arenas.terrain_generators.FLAT_PAD_M", -3.0)  # slopes under the first cycle's starts too
    flat = ImitationEnv(walk, EnvConfig())
    hills = ImitationEnv(walk, EnvConfig(terrain="slopes", terrain_difficulty=1.0))
    lifted = []
    for k in range(12):
        options = {"init": "rsi", "phase": k / 12}
        flat.reset(seed=k, options=options)
        hills.reset(seed=k, options=options)
        lifted.append(hills.data.qpos[2] - flat.data.qpos[2])
        # the same pose, lowest geom as far over the slope as over the floor (a foot on a 15 % grade: a few cm)
        assert abs(_lowest_foot_clearance(hills) - _lowest_foot_clearance(flat)) < 0.06
    assert max(lifted) > 0.2  # the starts were on hills, not all on the flat first metre


def test_a_terrain_env_observes_the_heightmap_last_and_logs_each_episodes_difficulty(walk):
    config = EnvConfig(terrain="mixed", terrain_difficulty=1.0, horizon_s=1.0)
    starts = BufferedStarts(ReferenceStarts("rsi", np.random.default_rng(0)), batch=4)
    env = VectorImitationEnv(walk, config, 3, starts, seed=0)
    obs = env.reset()
    assert obs.shape[1] == ImitationEnv(walk, EnvConfig()).obs_dim + HEIGHTMAP_DIM
    for _ in range(40):
        obs, *_ = env.step(np.zeros((3, env.action_dim), np.float32))
    # standing on its start: the ground near the root is about a pelvis height below it
    assert np.all(obs[:, -HEIGHTMAP_DIM:].max(axis=1) < -0.5)
    log = env.episodes.drain()
    assert len(log["terrain_difficulty"]) == len(log["fell"]) >= 3
    assert np.all(log["terrain_difficulty"][:3] == 0.0)  # the curriculum starts flat


def test_the_curriculum_climbs_after_long_episodes_and_steps_down_after_falls():
    c = TerrainCurriculum(2, top=0.8, control_hz=30.0)
    for _ in range(LEVELS + 3):
        c.update(0, fell=False, steps=60)
    assert c.difficulty(0) == pytest.approx(0.8)
    assert c.update(0, fell=True, steps=200) == pytest.approx(0.8 * (LEVELS - 1) / LEVELS)
    assert c.update(1, fell=False, steps=59) == 0.0  # too short to say
    assert c.update(1, fell=True, steps=10) == 0.0


def test_a_resumed_curriculum_starts_every_env_at_its_level_and_moves_from_there():
    fresh = TerrainCurriculum(3, top=0.8, control_hz=30.0)
    resumed = TerrainCurriculum(3, top=0.8, control_hz=30.0, start_level=4)
    assert [fresh.difficulty(i) for i in range(3)] == [0.0, 0.0, 0.0]  # a fresh run: flat ground, as before
    assert [resumed.difficulty(i) for i in range(3)] == pytest.approx([0.32] * 3)
    assert resumed.update(0, fell=True, steps=10) == pytest.approx(0.24)
    assert resumed.update(1, fell=False, steps=60) == pytest.approx(0.4)
    with pytest.raises(ValueError, match="start level"):
        TerrainCurriculum(3, top=0.8, control_hz=30.0, start_level=LEVELS + 1)


def test_a_vector_env_started_at_a_level_plays_its_first_episodes_there(walk):
    config = EnvConfig(terrain="mixed", terrain_difficulty=0.5, horizon_s=1.0)
    starts = BufferedStarts(ReferenceStarts("rsi", np.random.default_rng(0)), batch=4)
    env = VectorImitationEnv(walk, config, 2, starts, seed=0, terrain_start_level=6)
    assert env.terrain_levels().tolist() == [6, 6]
    env.reset()
    for _ in range(40):
        env.step(np.zeros((2, env.action_dim), np.float32))
    log = env.episodes.drain()
    assert len(log["terrain_difficulty"]) >= 2 and np.allclose(log["terrain_difficulty"][:2], 0.3)


def test_the_observation_layout_names_the_heightmap_block_last(walk):
    from actors.character.features import observation_layout

    env = ImitationEnv(walk, EnvConfig(terrain="gaps"))
    layout = observation_layout(env.humanoid.character, len(env.config.reference_obs_steps), 0, 0, env.heightmap_dim)
    assert layout[-1]["name"] == "heightmap" and layout[-1]["start"] + layout[-1]["size"] == env.obs_dim == env.observation_space.shape[0]


def test_an_episode_seed_gives_the_same_field_and_the_terrain_seed_another(walk):
    def field(terrain_seed, seed):
        env = ImitationEnv(walk, EnvConfig(terrain="mixed", terrain_seed=terrain_seed))
        env.reset(seed=seed)
        return env.model.hfield_data.copy()

    same, again = field(1000, 4), field(1000, 4)
    assert np.array_equal(same, again) and same.max() > same.min()
    assert not np.array_equal(same, field(1000, 5)) and not np.array_equal(same, field(0, 4))
