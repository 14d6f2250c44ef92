"""Task envs (go-to, push-box): observation layout, rewards, success, the box, falls, the worker."""
import numpy as np
import pytest

from actors.envs.tasks.config import TaskEnvConfig
from actors.envs.tasks.go_to import GoToTask

pytest.importorskip("pybullet_data", reason="task episodes start from the DeepMimic walk")


def make_env(task="go_to", num_envs=2, **kw):
    from actors.envs.tasks.vector_task_env import VectorTaskEnv

    return VectorTaskEnv(TaskEnvConfig(task=task, action="joint", **kw), num_envs, seed=3)


def hold_actions(env):
    """Joint actions whose PD targets are each env's current pose (stand still, roughly)."""
    mapper = env.action_space.mapper
    return np.stack([mapper.action_for_targets(d.ctrl.copy()) for d in env.datas]).astype(np.float32)


@pytest.mark.parametrize("task, width", [("go_to", 6), ("push_box", 11)])
def test_observation_is_proprioception_then_task_features(task, width):
    from actors.character.features import OBS_DIM, FeatureExtractor

    env = make_env(task)
    obs = env.reset()
    assert obs.shape == (2, 196 + width) and obs.dtype == np.float32 and np.isfinite(obs).all()
    obs, *_ = env.step(hold_actions(env))
    single = FeatureExtractor(env.humanoid)
    expected = single.observation(env.datas[1], 0.0, np.zeros(OBS_DIM))[:196]
    np.testing.assert_allclose(obs[1, :196], expected, rtol=1e-5, atol=1e-5)


def test_go_to_reward_is_highest_at_the_requested_speed_and_heading():
    task = GoToTask(TaskEnvConfig(), 3)
    task.target[:] = [[10.0, 0.0]] * 3
    task.speed[:] = 1.5
    task.heading[:] = 0.0
    vel = np.array([[1.5, 0.0], [0.5, 0.0], [-1.5, 0.0]])
    yaw = np.array([0.0, 0.0, np.pi])
    rewards, reached = task.rewards(np.zeros((3, 2)), vel, yaw, np.random.default_rng(0))
    assert rewards[0] == pytest.approx(1.0)
    assert rewards[0] > rewards[1] > rewards[2]
    assert not reached.any()


def test_reaching_the_target_pays_the_bonus_and_draws_a_new_target():
    config = TaskEnvConfig()
    task = GoToTask(config, 2)
    task.target[:] = [[0.1, 0.0], [4.0, 0.0]]
    rewards, reached = task.rewards(np.zeros((2, 2)), np.zeros((2, 2)), np.zeros(2), np.random.default_rng(0))
    assert reached.tolist() == [True, False]
    assert rewards[0] > config.success_bonus > rewards[1]
    lo, hi = config.target_distance
    assert lo <= np.linalg.norm(task.target[0]) <= hi


def test_an_env_at_its_target_logs_a_success():
    env = make_env("go_to", num_envs=1, horizon_s=0.2)
    env.reset()
    env.task.target[0] = env.features.pos[0, 0, :2]  # the target under the character
    env.step(hold_actions(env))
    assert env.reached[0]
    for _ in range(10):
        env.step(hold_actions(env))
    log = env.episodes.drain()
    assert log["successes"][0] and log["targets_reached"][0] >= 1
    assert log["first_success_s"][0] == pytest.approx(1 / 30)


def test_box_moves_when_pushed_and_rests_otherwise():
    env = make_env("push_box", num_envs=2)
    env.reset()
    q, v = env.task.qpos_adr, env.task.qvel_adr
    for i, data in enumerate(env.datas):
        yaw = np.arctan2(data.xmat[1, 3], data.xmat[1, 0])
        ahead = np.array([np.cos(yaw), np.sin(yaw)])
        data.qpos[q:q + 2] = data.qpos[:2] + (0.45 if i == 0 else 3.0) * ahead
        data.qvel[:2] = 2.0 * ahead  # env 0 walks into its box, env 1's box is far away
    start = [d.qpos[q:q + 2].copy() for d in env.datas]
    for _ in range(8):
        env.step(hold_actions(env))
    moved = [np.linalg.norm(d.qpos[q:q + 2] - s) for d, s in zip(env.datas, start)]
    assert moved[0] > 0.05
    assert moved[1] < 0.01
    assert np.abs(env.datas[1].qvel[v:v + 3]).max() < 0.05


def test_a_body_on_the_floor_is_a_fall_and_ends_the_episode():
    env = make_env("go_to", num_envs=1)
    env.reset()
    env.datas[0].qpos[2] = 0.15  # pelvis on the floor
    _, rewards, terminated, _, _ = env.step(hold_actions(env))
    assert terminated[0] and rewards[0] == 0.0
    assert env.episodes.drain()["fell"][0]


def test_task_worker_sample_matches_the_rollout_contract():
    from actors.rollout.task_worker import TaskRolloutWorker, TaskWorkerSpec
    from learner.config import PPOConfig
    from learner.ppo import PPOLearner

    spec = TaskWorkerSpec(TaskEnvConfig(action="joint", horizon_s=0.3), num_envs=3, seed=0)
    worker = TaskRolloutWorker(spec, 1)
    learner = PPOLearner(worker.env.obs_dim, worker.action_dim, PPOConfig(policy_hidden=(16,), value_hidden=(16,), reward_max=None))
    batch = worker.sample(learner.policy_weights(), 0, 12)
    assert batch["obs"].shape == (12, 3, 202) and batch["actions"].shape == (12, 3, 28)
    assert batch["truncated"].any() or batch["terminated"].any()
    assert len(batch["episode_successes"]) == int((batch["truncated"] | batch["terminated"]).sum())
    learner.update(batch)  # the learner takes it as it is


def test_a_module_that_is_not_one_is_one_clear_error(tmp_path, capsys):
    from services.cli import main

    assert main(["task", "go-to", "--module", str(tmp_path), "--out", str(tmp_path / "run")]) == 2
    assert "not a motor module" in capsys.readouterr().err
    assert "--module" in " ".join(TaskEnvConfig(module=None).problems())


def test_pose_prior_prefers_expert_poses_to_random_ones():
    from services.tasks.pose_prior import PosePrior, clip_poses

    prior = PosePrior.fit(("walk", "run"))
    rng = np.random.default_rng(0)
    assert prior.log_density(clip_poses("walk")).mean() > prior.log_density(rng.uniform(-1, 1, (50, 28))).mean() + 50


def _box_contacts_after(env, data, centre):
    """Move env's push box to `centre` (x, y, z of its middle), recompute contacts, and return
    (fall?, names of walker bodies touching the box)."""
    import mujoco

    q = env.task.qpos_adr
    data.qpos[q:q + 3] = centre
    data.qpos[q + 3:q + 7] = (1.0, 0.0, 0.0, 0.0)
    mujoco.mj_forward(env.model, data)
    box = mujoco.mj_name2id(env.model, mujoco.mjtObj.mjOBJ_GEOM, "box_geom")
    touching = set()
    for g1, g2 in data.contact.geom:
        if box in (g1, g2):
            other = g2 if g1 == box else g1
            touching.add(mujoco.mj_id2name(env.model, mujoco.mjtObj.mjOBJ_BODY, env.model.geom_bodyid[other]))
    return env.fall(data), touching


def test_torso_on_the_push_box_is_a_fall_but_a_hand_on_it_is_not():
    import mujoco

    env = make_env("push_box", num_envs=1)
    env.reset()
    data = env.datas[0]
    mujoco.mj_forward(env.model, data)
    half = env.model.geom_size[mujoco.mj_name2id(env.model, mujoco.mjtObj.mjOBJ_GEOM, "box_geom")]
    ids = {name: mujoco.mj_name2id(env.model, mujoco.mjtObj.mjOBJ_BODY, name) for name in ("chest", "right_wrist", "root")}
    chest = data.xpos[ids["chest"]].copy()
    fell, touching = _box_contacts_after(env, data, (chest[0], chest[1], chest[2] - half[2] + 0.05))
    assert "chest" in touching and fell  # leaning the trunk on the box
    wrist, pelvis = data.xpos[ids["right_wrist"]].copy(), data.xpos[ids["root"]].copy()
    out = (wrist[:2] - pelvis[:2]) / np.linalg.norm(wrist[:2] - pelvis[:2])
    fell, touching = _box_contacts_after(env, data, (*(wrist[:2] + out * (half[0] + 0.02)), wrist[2]))
    assert "right_wrist" in touching and not fell  # a hand pushing


def test_starts_come_from_every_listed_clip_at_their_own_speeds():
    from actors.character.humanoid import PhysicsConfig
    from actors.envs.tasks.starts import ClipStarts

    starts = ClipStarts("deepmimic:walk, deepmimic:run", PhysicsConfig(), 1.0 / 30.0)
    rng = np.random.default_rng(0)
    speeds = np.array([np.linalg.norm(starts.take(rng)[1][:2]) for _ in range(200)])
    walk_like, run_like = (speeds < 2.0).mean(), (speeds > 2.5).mean()
    assert 0.3 < walk_like < 0.7 and 0.3 < run_like < 0.7  # a clip is drawn first: about half each
    assert all(abs(q[:, :2]).max() == 0.0 for q in starts.qpos)  # every start above the origin
    assert "--start-motion must name at least one clip" in TaskEnvConfig(start_motion=" , ").problems()
