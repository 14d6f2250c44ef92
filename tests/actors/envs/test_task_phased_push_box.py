"""The phased push-box (actors/envs/tasks/phased_push_box.py): a box of its own size and mass per
episode and env, starts in both phases, a sparse reward per phase, progress paid per metre."""
import numpy as np
import pytest

from actors.envs.tasks.config import TaskEnvConfig
from actors.envs.tasks.phased_push_box import GOTO, PUSH, REACH_M, PhasedPushBoxTask

pytest.importorskip("pybullet_data", reason="task episodes start from the DeepMimic walk")


def make_env(num_envs=4, **kw):
    from actors.envs.tasks.vector_task_env import VectorTaskEnv

    return VectorTaskEnv(TaskEnvConfig(task="push_box_phased", action="joint", **kw), num_envs, seed=5)


def hold_actions(env):
    mapper = env.action_space.mapper
    return np.stack([mapper.action_for_targets(d.ctrl.copy()) for d in env.datas]).astype(np.float32)


def test_each_env_pushes_a_box_of_its_own_size_and_mass_that_rests_on_the_floor():
    env = make_env(num_envs=6, push_start_share=0.0, box_distance=(4.0, 5.0))  # every box 4-5 m away: nothing touches it
    obs = env.reset()
    task, q = env.task, env.task.qpos_adr
    assert obs.shape == (6, 196 + PhasedPushBoxTask.obs_dim) and np.isfinite(obs).all()
    sizes = np.array([m.geom_size[task.geom] for m in env.sim.models])
    masses = np.array([m.body_mass[task.body] for m in env.sim.models])
    np.testing.assert_allclose(sizes, task.half_size)
    np.testing.assert_allclose(masses, task.mass)
    assert len(np.unique(masses)) == 6 and np.ptp(sizes[:, 2]) > 0.01  # drawn per env
    lo, hi = env.config.box_mass
    assert ((masses >= lo) & (masses <= hi)).all()
    # A solid box's inertia for its size and mass, and the box stands flush: its centre its half height up.
    a, b, h = 2 * sizes[0]
    np.testing.assert_allclose(env.sim.models[0].body_inertia[task.body], masses[0] / 12 * np.array([b*b + h*h, a*a + h*h, a*a + b*b]))
    # MuJoCo's derived constants follow (mj_setConst): the box's inverse weight is its model's, a lighter box's larger.
    invweight = np.array([m.body_invweight0[task.body, 0] for m in env.sim.models])
    assert np.all(np.diff(invweight[np.argsort(masses)]) < 0)
    heights = np.array([d.qpos[q + 2] for d in env.datas])
    np.testing.assert_allclose(heights, sizes[:, 2], atol=1e-9)
    for _ in range(10):
        env.step(hold_actions(env))
    assert (env._len == 10).all()  # no env ended (and drew a new box)
    after = np.array([d.qpos[q + 2] for d in env.datas])
    np.testing.assert_allclose(after, sizes[:, 2], atol=5e-3)  # resting on the floor: its own height, not the arena's
    # The policy sees its box: phase one-hot, half sizes, mass / 10.
    base = env.proprio_dim + 11
    np.testing.assert_allclose(env.obs[:, base + 2:base + 5], task.half_size, rtol=1e-6)
    np.testing.assert_allclose(env.obs[:, base + 5], task.mass / 10, rtol=1e-6)


def test_episodes_start_in_both_phases_the_push_phase_beside_the_box():
    env = make_env(num_envs=32, push_start_share=0.5)
    env.reset()
    task = env.task
    distance = np.linalg.norm(task.box[:, :2] - env.features.pos[:, 0, :2], axis=1)
    pushing = task.phase == PUSH
    assert 0 < pushing.sum() < 32
    reach = task.half_size[:, :2].max(axis=1)
    assert (distance[pushing] <= reach[pushing] + 0.5 + 1e-9).all() and (distance[pushing] >= reach[pushing] + 0.3 - 1e-9).all()
    assert (distance[~pushing] >= 1.0 - 1e-9).all()
    obs = env.obs[:, env.proprio_dim + 11:env.proprio_dim + 13]
    np.testing.assert_array_equal(obs[:, 1], pushing)
    assert (make_env(num_envs=8, push_start_share=0.0).task.phase == GOTO).all()


def test_a_sparse_reward_per_phase_and_no_shaping_across_a_phase_change():
    config = TaskEnvConfig(task="push_box_phased", box_shaping=0.0)
    task = PhasedPushBoxTask(config, 3)
    task.box[:, :2] = [[1.0, 0.0], [0.3, 0.0], [5.0, 0.0]]
    task.target[:] = [[3.0, 0.0], [3.0, 0.0], [5.2, 0.0]]
    task.phase[:] = [GOTO, GOTO, PUSH]
    rng = np.random.default_rng(0)
    task.box_vel[2] = [1.0, 0.0]  # sliding through its target circle: not delivered yet
    assert task.rewards(np.zeros((3, 2)), np.zeros((3, 2)), np.zeros(3), rng)[1].tolist() == [False, False, False]
    task.phase[:] = [GOTO, GOTO, PUSH]
    task.box_vel[2] = [0.1, 0.0]  # it stops there
    rewards, delivered = task.rewards(np.zeros((3, 2)), np.zeros((3, 2)), np.zeros(3), rng)
    # env 0 is 1 m from its box (farther than REACH_M): nothing; env 1 reaches it; env 2's box is at its target.
    assert rewards.tolist() == [0.0, config.success_bonus, config.success_bonus]
    assert delivered.tolist() == [False, False, True] and task.phase_reached.tolist() == [False, True, False]
    assert task.phase.tolist() == [GOTO, PUSH, PUSH]
    assert np.linalg.norm(task.target[2] - [5.0, 0.0]) >= config.box_target_distance[0]  # a new target beyond the box


def test_progress_toward_the_phases_goal_is_paid_per_metre_and_standing_still_earns_nothing():
    task = PhasedPushBoxTask(TaskEnvConfig(task="push_box_phased", box_shaping=1.0), 3)
    task.box[:, :2] = [[3.0, 0.0], [3.0, 0.0], [0.5, 0.0]]
    task.target[:] = [[6.0, 0.0], [6.0, 0.0], [3.0, 0.0]]
    task.phase[:] = [GOTO, GOTO, PUSH]
    task._distance[:] = [3.0 - REACH_M, 3.0 - REACH_M, 2.8]  # env 2's box was 2.8 m from its target
    walked = np.array([[0.5, 0.0], [0.0, 0.0], [0.0, 0.0]])  # env 0 walks half a metre toward its box, env 1 stays
    rewards, _ = task.rewards(walked, np.zeros((3, 2)), np.zeros(3), np.random.default_rng(0))
    np.testing.assert_allclose(rewards, [0.5, 0.0, 0.3], atol=1e-12)  # env 2's box moved 0.3 m toward its target
    rewards, _ = task.rewards(walked, np.zeros((3, 2)), np.zeros(3), np.random.default_rng(0))
    np.testing.assert_allclose(rewards, 0.0, atol=1e-12)  # no progress, nothing paid


def test_bad_phased_settings_are_named():
    problems = TaskEnvConfig(task="push_box_phased", push_start_share=1.5, box_mass=(5.0, 1.0), box_shaping=-1).problems()
    assert any("--env.push-start-share" in p for p in problems)
    assert any("--box-mass" in p for p in problems)
    assert any("--env.box-shaping" in p for p in problems)


def test_episodes_log_their_start_phase_and_whether_the_box_was_reached():
    """An env started in the go-to phase with its box put under the walker logs the box reached; the
    eval's split and the training figure read those logs (other tasks log -1 and get no figure)."""
    from services.tasks.driver import task_figures
    from services.tasks.evaluation import split_by_start_phase

    env = make_env(num_envs=2, push_start_share=0.0, horizon_s=0.2)
    env.reset()
    q = env.task.qpos_adr
    env.datas[0].qpos[q:q + 2] = env.features.pos[0, 0, :2] + [0.5, 0.0]  # env 0's box within reach
    env.task.box[0, :2] = env.datas[0].qpos[q:q + 2]
    for _ in range(6):
        env.step(hold_actions(env))
    log = env.episodes.drain()
    assert log["start_phase"][:2].tolist() == [0, 0]
    assert log["first_phase_done"][:2].tolist() == [True, False]
    split = split_by_start_phase(log)
    assert split["go_to_the_box"]["episodes"] == 2 and split["go_to_the_box"]["box_reached_rate"] == 0.5
    batch = {f"episode_{k}": v for k, v in log.items()}
    assert task_figures(batch)["box_reached_rate"] == 0.5
    other = {**batch, "episode_start_phase": np.full(2, -1.0)}
    assert "box_reached_rate" not in task_figures(other)
