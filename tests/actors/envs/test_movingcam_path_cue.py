"""The movingcam mode's path cue (issue 48 part 2): the estimated root path ahead in the
character's heading frame, a reward for following it, and nothing of it without a root_path."""
import copy
import dataclasses

import mujoco
import numpy as np
import pytest

from actors.character.features import obs_dim, update_kinematics
from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.envs.modes.movingcam.path_cue import path_velocities
from actors.envs.modes.movingcam.tracking import MovingcamConfig

SPEED = 1.2  # m/s along the world's +x
CUE = EnvConfig(mode="movingcam", horizon_s=2.0, movingcam=MovingcamConfig(path_weight=0.2))


@pytest.fixture(scope="module")
def straight():
    """The walk, root-free with its cues, its estimated path a straight line at SPEED along +x."""
    pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")
    from actors.envs.modes.movingcam.clip_cues import clip_cues
    from actors.motion.formats.io import load_motion
    from services.reconstruction.root_free import make_root_free

    walk = load_motion("deepmimic:walk")
    free = make_root_free(walk)
    free.extras.update(clip_cues(walk))
    t = free.frame_times
    free.extras["root_path"] = np.stack([SPEED * t, np.zeros_like(t), np.full_like(t, 0.9)], axis=1)
    free.extras["root_path_confidence"] = np.ones(len(t))
    return free


def _turn_to(env, yaw: float) -> None:
    """The character turned to face `yaw` (rad) about the vertical, its pose otherwise kept."""
    half = np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])
    q = np.empty(4)
    mujoco.mju_mulQuat(q, half, env.data.qpos[3:7] / np.linalg.norm(env.data.qpos[3:7]))
    env.data.qpos[3:7] = q
    update_kinematics(env.model, env.data)


def _path_slots(env) -> np.ndarray:
    obs = env.observation_into(np.zeros(env.observation_space.shape, np.float32))
    start = obs_dim(env.humanoid.character) - 1  # the reference slots sit before the phase
    return obs[start:start + 6].reshape(2, 3)[:, :2]  # steps 1 and 15 ahead (the default)


def _yaw(env) -> float:
    xmat = env.data.xmat[1]
    return float(np.arctan2(xmat[3], xmat[0]))


def test_a_straight_path_is_observed_as_its_speed_ahead_in_the_heading_frame(straight):
    env = ImitationEnv(straight, CUE)
    env.reset(seed=0, options={"init": "fsi"})
    for turn in (0.0, np.pi / 2, -2.5):
        _turn_to(env, turn - _yaw(env))
        yaw = _yaw(env)
        assert yaw == pytest.approx(np.arctan2(np.sin(turn), np.cos(turn)), abs=1e-6)
        slots = _path_slots(env)  # steps 1 and 15 ahead: (speed x, speed y) in the character's frame
        expected = SPEED * np.array([np.cos(yaw), -np.sin(yaw)])
        np.testing.assert_allclose(slots, np.tile(expected, (2, 1)), atol=1e-6)
        assert np.hypot(*slots[1]) == pytest.approx(SPEED, abs=1e-6)


def _reward_moving_at(env, velocity_xy) -> float:
    env.reset(seed=0, options={"init": "fsi"})
    env.data.qvel[:2] = velocity_xy  # the root's world velocity; nothing else of the state changes
    update_kinematics(env.model, env.data)
    return env.reward_at(env.row)


def test_following_the_path_earns_more_than_standing_by_the_path_term(straight):
    env = ImitationEnv(straight, CUE)
    follow, stand, across = (_reward_moving_at(env, v) for v in ((SPEED, 0.0), (0.0, 0.0), (0.0, SPEED)))
    assert follow > stand and follow > across
    # The centre of mass moves at the root's velocity plus the joints' own: the gain is the
    # path term's 0.2 (1 - exp(-2 v^2)) = 0.19 up to those.
    assert follow - stand == pytest.approx(0.2 * (1 - np.exp(-2.0 * SPEED**2)), abs=0.05)
    assert env.max_reward == pytest.approx(MovingcamConfig().reward.max_reward + 0.2)


def test_without_a_root_path_or_with_weight_0_nothing_changes(straight):
    off = dataclasses.replace(CUE, movingcam=MovingcamConfig(path_weight=0.0))
    no_path = copy.copy(straight)
    no_path.extras = {k: v for k, v in straight.extras.items() if not k.startswith("root_path")}
    for env in (ImitationEnv(straight, off), ImitationEnv(no_path, CUE)):
        assert not env.movingcam.path.active
        assert _reward_moving_at(env, (SPEED, 0.0)) == pytest.approx(_reward_moving_at(env, (0.0, 0.0)), abs=1e-12)
        np.testing.assert_array_equal(_path_slots(env), 0.0)
        assert env.max_reward == pytest.approx(MovingcamConfig().reward.max_reward)


def test_path_velocity_is_the_travel_over_a_stride_not_the_surge_or_the_sway():
    t = np.arange(0, 4, 1 / 30)
    surge = 0.03 * np.sin(2 * np.pi * 2 * t)  # each step's push, 2 Hz
    sway = 0.03 * np.sin(2 * np.pi * 1 * t)  # side to side over a stride, 1 Hz: 0.19 m/s at its fastest
    v = path_velocities(np.stack([0.8 * t + surge, sway, np.zeros_like(t)], axis=1), t)
    inner = slice(15, -15)  # half a stride from the ends, where the span is centred
    assert np.abs(v[inner, 0] - 0.8).max() < 0.02 and np.abs(v[inner, 1]).max() < 0.02
    assert np.abs(np.gradient(sway, t)).max() > 0.18  # what a frame-to-frame velocity would turn by


def test_the_vector_env_observes_and_pays_the_path_as_single_envs_do(straight):
    from actors.envs.initial_states import BufferedStarts, ReferenceStarts
    from actors.envs.vector_env import VectorImitationEnv

    venv = VectorImitationEnv(straight, CUE, num_envs=3, starts=BufferedStarts(ReferenceStarts("rsi", np.random.default_rng(3)), batch=3), seed=5)
    venv.reset()
    singles = []
    for i, inner in enumerate(venv.envs):
        single = ImitationEnv(straight, CUE)
        obs, _ = single.reset(seed=0, options={"init": "rsi", "phase": inner.phase})
        np.testing.assert_array_equal(obs, venv.obs[i])
        singles.append(single)
    rng = np.random.default_rng(1)
    alive, paid = np.ones(3, dtype=bool), []
    for _ in range(10):
        actions = rng.uniform(-1, 1, (3, venv.action_dim))
        _, rewards, terminated, truncated, final_obs = venv.step(actions)
        paid.append(venv.core.mode.tracking.path.reward(venv.core.rows, venv.core.features.com_vel).copy())
        for i, single in enumerate(singles):
            if alive[i]:
                obs, reward, term, trunc, _ = single.step(actions[i])
                assert reward == pytest.approx(float(rewards[i]), abs=1e-6)
                np.testing.assert_allclose(obs, final_obs[i], atol=1e-5)
                alive[i] = not (term or trunc)
    assert np.max(paid) > 0.0  # the path term was part of those rewards
