"""The scene in the env: the normalised scene vector is the observation's last entries (the
rest unchanged), it is drawn per episode in the domain unless fixed, the vector env carries
it per env, and without a scene file the env is the flat floor it was."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from actors.character.features import observation_dim
from actors.character.humanoid3d import Humanoid
from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.envs.initial_states import BufferedStarts, ReferenceStarts
from actors.motion.formats.io import load_motion
from actors.envs.vector_env import VectorImitationEnv

SCENES = Path(__file__).resolve().parents[3] / "bench" / "scenes"


@pytest.fixture(scope="module")
def clip():
    return load_motion(str(SCENES / "box_jump.npz"))


@pytest.fixture(scope="module")
def scene_env(clip):
    return ImitationEnv(clip, EnvConfig(scene=str(SCENES / "box_jump.yaml")))


def test_the_scene_vector_is_the_observation_tail(clip, scene_env):
    flat = ImitationEnv(clip, EnvConfig())
    assert scene_env.obs_dim == flat.obs_dim + 2
    low, high = scene_env.scene.bounds()
    e1, e2 = low + 0.25 * (high - low), high - 0.1 * (high - low)
    obs1, _ = scene_env.reset(seed=3, options={"init": "fsi", "scene": e1})
    obs2, _ = scene_env.reset(seed=3, options={"init": "fsi", "scene": e2})
    reference, _ = flat.reset(seed=3, options={"init": "fsi"})
    np.testing.assert_allclose(obs1[-2:], [-0.5, -0.5], atol=1e-6)
    np.testing.assert_allclose(obs2[-2:], [0.8, 0.8], atol=1e-6)
    np.testing.assert_array_equal(obs1[:-2], reference)
    step, *_ = scene_env.step(np.zeros(scene_env.action_space.shape))
    np.testing.assert_allclose(step[-2:], [0.8, 0.8], atol=1e-6)


def test_episodes_draw_the_scene_unless_it_is_fixed(scene_env):
    low, high = scene_env.scene.bounds()
    drawn = []
    for seed in range(6):
        scene_env.reset(seed=seed)
        drawn.append(scene_env.scene_vector.copy())
        (box,) = scene_env.arena.box_geom_ids(scene_env.model)
        assert scene_env.model.geom_pos[box, 2] + scene_env.model.geom_size[box, 2] == pytest.approx(scene_env.scene_vector[1], abs=1e-3)
    drawn = np.array(drawn)
    assert np.all(drawn >= low) and np.all(drawn <= high) and np.ptp(drawn, axis=0).min() > 0.05
    fixed = np.array([1.0, 0.25])
    scene_env.set_scene(fixed)
    for seed in range(3):
        obs, _ = scene_env.reset(seed=seed)
        np.testing.assert_array_equal(scene_env.scene_vector, fixed)
        np.testing.assert_allclose(obs[-2:], scene_env.scene.normalise(fixed), atol=1e-6)
    scene_env.set_scene(None)
    with pytest.raises(ValueError, match="2 finite numbers"):
        scene_env.set_scene([1.0])


def test_the_vector_env_keeps_each_envs_scene_in_its_row(clip):
    config = EnvConfig(scene=str(SCENES / "box_jump.yaml"))
    starts = BufferedStarts(ReferenceStarts("rsi", np.random.default_rng(0)), 8)
    vec = VectorImitationEnv(clip, config, 3, starts, seed=5)
    obs = vec.reset()
    models = {id(env.model) for env in vec.envs}
    assert len(models) == 3  # each env moves its own boxes
    for _ in range(12):
        obs, rewards, *_ = vec.step(np.zeros((3, vec.action_dim), np.float32))
        for i, env in enumerate(vec.envs):
            np.testing.assert_allclose(obs[i, -2:], env.scene.normalise(env.scene_vector), atol=1e-6)
            (box,) = env.arena.box_geom_ids(env.model)
            assert env.model.geom_size[box, 2] == pytest.approx(max(env.scene_vector[1] / 2, 5e-4))
    assert len({tuple(env.scene_vector) for env in vec.envs}) == 3


def test_without_a_scene_file_the_env_is_the_flat_floor(clip):
    env = ImitationEnv(clip, EnvConfig())
    assert env.scene is None and env.scene_reward is None and env.model is env.humanoid.model
    assert env.obs_dim == observation_dim(len(EnvConfig().reference_obs_steps))
    assert env.model.ngeom == Humanoid().model.ngeom and env.model.npair == Humanoid().model.npair
    env.reset(seed=0)
    assert env.max_episode_return() == env.max_reward * env.max_episode_steps


def test_the_vector_env_earns_what_a_single_env_earns_on_the_same_scene(clip):
    config = EnvConfig(scene=str(SCENES / "box_jump.yaml"))
    vec = VectorImitationEnv(clip, config, 1, BufferedStarts(ReferenceStarts("fsi", np.random.default_rng(0)), 4), seed=7)
    single = ImitationEnv(clip, config)
    vec_obs = vec.reset()
    obs, _ = single.reset(seed=7, options={"phase": 0.0, "init": "rsi"})
    np.testing.assert_array_equal(vec.envs[0].scene_vector, single.scene_vector)
    np.testing.assert_allclose(vec_obs[0], obs, atol=1e-6)
    rng = np.random.default_rng(1)
    for _ in range(40):
        action = rng.normal(0.0, 0.05, (1, vec.action_dim)).astype(np.float32)
        vec_obs, vec_reward, terminated, truncated, _ = vec.step(action)
        obs, reward, *_ = single.step(action[0])
        if terminated[0] or truncated[0]:
            break
        assert vec_reward[0] == pytest.approx(reward, abs=1e-5)
        np.testing.assert_allclose(vec_obs[0], obs, atol=1e-4)
    assert single.row > 20  # into the flight rows, where r_com is scored


def test_value_targets_are_bounded_by_the_scene_reward_too(clip, scene_env):
    """A return with boxes can exceed the imitation reward's bound: the bound PPO clips value
    targets at (`EnvConfig.max_reward`) includes the scene reward's most per step."""
    from learner.config import PPOConfig
    from learner.ppo import PPOLearner

    flat = EnvConfig()
    boxes = EnvConfig(scene=str(SCENES / "box_jump.yaml"))
    per_step = float(scene_env.scene_reward.max_rewards.max())
    assert per_step > 0
    assert boxes.max_reward >= flat.max_reward + per_step - 1e-12
