"""Task envs on SFV Fig. 8's slope: the inclined plane, starts set down on it, the box flush, falls
measured from the ground, the grade in the observation and the eval's up / down split."""
import mujoco
import numpy as np
import pytest

from actors.arenas.push_box import PushBoxArena
from actors.arenas.slope import SlopeFloor
from actors.character.humanoid3d import HUMANOID3D
from actors.envs.tasks.config import TaskEnvConfig
from actors.envs.tasks.slope_starts import turn_start

GRADE = 0.15


def ground_by_ray(model, data, xy):
    """The height where a ray cast straight down at `xy` meets the floor geom."""
    floor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    hit = np.zeros(1, np.int32)
    start = np.array([xy[0], xy[1], 10.0])
    distance = mujoco.mj_ray(model, data, start, np.array([0.0, 0.0, -1.0]), None, 1, -1, hit)
    assert hit[0] == floor
    return 10.0 - distance


def test_the_plane_in_the_model_is_where_height_at_says():
    humanoid = HUMANOID3D.build(arena=PushBoxArena(floor=SlopeFloor(GRADE)))
    data = mujoco.MjData(humanoid.model)
    data.qpos[2] = 50.0  # the walker out of the rays' way
    mujoco.mj_forward(humanoid.model, data)
    floor = SlopeFloor(GRADE)
    for xy in ([0.0, 0.0], [4.0, 1.0], [-6.0, -2.5]):
        assert ground_by_ray(humanoid.model, data, xy) == pytest.approx(float(floor.height_at(np.array(xy))), abs=1e-6)


def test_a_bad_grade_is_a_one_line_error_naming_the_flag():
    problems = TaskEnvConfig(slope=1.5).problems()
    assert any(p.startswith("--slope must lie in [0, 1]") for p in problems)
    assert not TaskEnvConfig(slope=GRADE).problems()
    with pytest.raises(ValueError, match="--slope"):
        SlopeFloor(float("nan"))


def test_turning_a_start_turns_its_heading_and_velocity_about_the_root():
    qpos = np.zeros(7)
    qpos[3] = 1.0
    qvel = np.array([1.3, 0.0, 0.2, 0.5, -0.1, 0.3])
    turn_start(qpos, qvel, np.pi / 2)
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, qpos[3:7])
    np.testing.assert_allclose(rot.reshape(3, 3)[:, 0], [0.0, 1.0, 0.0], atol=1e-12)  # +x now points along +y
    np.testing.assert_allclose(qvel, [0.0, 1.3, 0.2, 0.5, -0.1, 0.3], atol=1e-12)  # the local angular velocity stays


pytest.importorskip("pybullet_data", reason="task episodes start from the DeepMimic walk")


def make_env(task="push_box", num_envs=6, slope=GRADE, seed=5):
    from actors.envs.tasks.vector_task_env import VectorTaskEnv

    return VectorTaskEnv(TaskEnvConfig(task=task, action="joint", slope=slope), num_envs, seed=seed)


def hold_actions(env):
    mapper = env.action_space.mapper
    return np.stack([mapper.action_for_targets(d.ctrl.copy()) for d in env.datas]).astype(np.float32)


def test_starts_face_every_way_and_stand_on_the_incline_as_on_the_flat():
    flat, sloped = make_env(slope=0.0), make_env()
    flat_obs, obs = flat.reset(), sloped.reset()
    assert obs.shape == (6, 196 + 2 + 11) and flat_obs.shape == (6, 196 + 11)
    _, _, yaw = sloped.planar_state()
    assert np.ptp(np.cos(yaw)) > 0.5  # turned starts, not all up the slope
    floor = SlopeFloor(GRADE)
    for data in sloped.datas:  # no walker geom below the incline by more than its flat start's clearance allows
        geoms = sloped._walker_geoms
        clearance = data.geom_xpos[geoms, 2] - floor.height_at(data.geom_xpos[geoms, :2])
        assert clearance.min() > 0.0
    # The decoder's root-height feature is the height above the ground: a flat start's range.
    assert 0.6 < obs[:, 0].min() and obs[:, 0].max() < 1.1
    # The grade as each character faces it: (g cos yaw, -g sin yaw).
    np.testing.assert_allclose(obs[:, 196], GRADE * np.cos(yaw), atol=1e-5)
    np.testing.assert_allclose(obs[:, 197], -GRADE * np.sin(yaw), atol=1e-5)


def test_the_box_rests_flush_on_the_incline_and_stays():
    env = make_env(num_envs=4)
    env.reset()
    start = env.task.box.copy()
    lift = env.arena.half_size[2] / np.cos(np.arctan(GRADE))
    np.testing.assert_allclose(start[:, 2] - env.arena.height_at(start[:, :2]), lift, atol=1e-6)
    for _ in range(15):  # half a second, the characters holding their poses
        env.step(hold_actions(env))
    moved = np.linalg.norm(env.task.box[:, :2] - start[:, :2], axis=1)
    untouched = (np.linalg.norm(env.task.box[:, :2] - env.planar_state()[0], axis=1) > 0.9) & (env.rows == 15)  # not reset since
    assert untouched.any()
    assert moved[untouched].max() < 0.02  # 15 % < the box's 0.4 friction: it does not slide
    np.testing.assert_allclose(env.task.box[untouched, 2] - env.arena.height_at(env.task.box[untouched, :2]), lift, atol=0.01)


def test_the_pelvis_height_rule_measures_from_the_ground_under_it():
    from actors.envs.tasks.floor_fall import FloorFall

    env = make_env(num_envs=1)
    env.reset()
    data = env.datas[0]
    data.qpos[0] = -5.0  # 0.75 m below z = 0 on the incline
    data.qpos[2] = float(env.arena.height_at(data.qpos[:2])) + 0.9
    data.qpos[1] = 0.0
    mujoco.mj_forward(env.model, data)
    assert not env.fall(data)
    assert FloorFall(env.humanoid)(data)  # measured from z = 0, the same pelvis is 'below 0.3 m'


def test_episodes_log_the_grade_along_their_first_push():
    env = make_env(num_envs=8)
    env.reset()
    along = env._grade_along.copy()
    for i in range(env.num_envs):
        expected = GRADE * env.task.first_direction(i)[0]
        assert along[i] == pytest.approx(expected)
    assert (np.abs(along) <= GRADE + 1e-9).all() and np.ptp(along) > 0.1


def test_the_eval_splits_up_down_and_across():
    from services.tasks.evaluation import split_by_direction

    per_episode = {"grade_along": np.array([0.15, 0.1, -0.14, 0.0, -0.02, -0.09]),
                   "successes": np.array([1, 0, 1, 1, 0, 0]), "fell": np.array([0, 1, 0, 0, 0, 1])}
    split = split_by_direction(per_episode, GRADE)
    assert split["up"] == {"episodes": 2, "success_rate": 0.5, "fall_rate": 0.5}
    assert split["down"] == {"episodes": 2, "success_rate": 0.5, "fall_rate": 0.5}
    assert split["across"] == {"episodes": 2, "success_rate": 0.5, "fall_rate": 0.0}
