"""The envs build the character their config names (`EnvConfig.character`), the G1 beside humanoid3d.

The G1's tests need its cached model (`sfv models fetch --robot g1`) and skip without it."""
import numpy as np
import pytest

from actors.character import g1_model
from actors.character.characters import CHARACTER_NAMES, character_named
from actors.character.features import observation_dim
from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.envs.initial_states import BufferedStarts, ReferenceStarts
from actors.envs.vector_env import VectorImitationEnv

needs_g1 = pytest.mark.skipif(not g1_model.model_available(), reason="G1 model not cached (sfv models fetch --robot g1)")
G1 = EnvConfig(character="g1", horizon_s=1.0)


@pytest.fixture(scope="module")
def g1_walk(walk_clip, tmp_path_factory):
    """The walk retargeted onto the G1 and saved as a robot motion file at exactly 30 fps, so
    that the control grid's rows are the file's frames."""
    if not g1_model.model_available():
        pytest.skip("G1 model not cached (sfv models fetch --robot g1)")
    import dataclasses

    from actors.motion.robot_motion import save_robot_motion
    from actors.motion.robot_retarget import retarget_to_g1

    robot, _ = retarget_to_g1(walk_clip)
    robot = dataclasses.replace(robot, fps=30.0)
    return robot, save_robot_motion(robot, tmp_path_factory.mktemp("g1") / "walk_g1.npz")


@pytest.fixture(scope="module")
def g1_env(g1_walk):
    from actors.motion.character_reference import load_reference

    return ImitationEnv(load_reference(str(g1_walk[1]), character_named("g1")), G1)


def test_both_bodies_are_registered_and_humanoid3d_is_the_default():
    assert CHARACTER_NAMES == ("humanoid3d", "g1")
    assert EnvConfig().character == "humanoid3d"
    with pytest.raises(ValueError, match="character must be one of humanoid3d, g1, got 'atlas'"):
        EnvConfig(character="atlas")


def test_the_humanoid_env_is_the_humanoid3d(walk_clip):
    env = ImitationEnv(walk_clip, EnvConfig(horizon_s=0.5))
    assert env.humanoid.character.name == "humanoid3d" and env.model.nu == 28 and env.motion is walk_clip


def test_modes_and_links_of_another_body_are_refused_in_one_line():
    with pytest.raises(ValueError, match="env mode movingcam follows the humanoid3d only, not the g1"):
        EnvConfig(character="g1", mode="movingcam")
    with pytest.raises(ValueError, match=r"ground contact links \['left_wrist'\] are not links of the g1"):
        EnvConfig(character="g1", ground_contact_links=("left_wrist",))
    EnvConfig(character="g1", ground_contact_links=("left_wrist_yaw_link",))


@needs_g1
def test_g1_env_builds_the_g1_and_steps(g1_env):
    env = g1_env
    g1 = character_named("g1")
    # Not the humanoid under another name: the G1's model, actions, observation and state.
    assert env.humanoid.character is g1 and env.motion.character == "g1"
    assert (env.model.nq, env.model.nv, env.model.nu) == (36, 35, 29)
    assert env.action_space.shape == (29,) and env.obs_dim == observation_dim(2, g1) == 406
    assert env.state_dim == 1 + 3 + 29 + 35
    obs, info = env.reset(seed=3)
    assert obs.shape == (406,) and np.isfinite(obs).all()
    rewards = []
    for _ in range(10):
        obs, reward, terminated, truncated, _ = env.step(np.zeros(29))
        assert np.isfinite(obs).all() and not terminated
        rewards.append(reward)
    assert 0.5 < np.mean(rewards) <= 1.0  # zero residuals track the reference for a few steps


@needs_g1
def test_g1_reference_state_reset_reproduces_the_robot_motion(g1_env, g1_walk):
    robot, _ = g1_walk
    env = g1_env
    qpos = robot.qpos()
    for seed in range(4):
        _, info = env.reset(seed=seed, options={"init": "rsi"})
        k = info["start_step"]
        np.testing.assert_allclose(env.data.qpos, qpos[k], atol=1e-9)
        np.testing.assert_allclose(env.data.qvel, env.track.qvel[k], atol=1e-9)  # the start's (spikes filtered)
        if 0 < k < robot.num_frames - 1:  # the reference's joint rates: the central difference of the frames
            rates = (robot.joint_pos[k + 1] - robot.joint_pos[k - 1]) * robot.fps / 2.0
            np.testing.assert_allclose(env.track.reference_qvel[k, 6:], rates, atol=1e-6)
    env.reset(options={"init": "fsi"})
    np.testing.assert_allclose(env.data.qpos, qpos[0], atol=1e-9)
    # The ASI state vector of a reference row puts the same pose back.
    state = env.reference_state_vector(7)
    env.reset(options={"init": "state", "state": state, "phase": env.track.phase[7]})
    np.testing.assert_allclose(env.data.qpos, qpos[7], atol=1e-9)


@needs_g1
def test_g1_reward_is_one_when_it_plays_its_reference(g1_env):
    env = g1_env
    for row in (0, 5, 17, 30):
        env.set_reference_state(row)
        assert env.reward_at(row) == pytest.approx(1.0, abs=1e-9)
    env.set_reference_state(5)
    assert env.reward_at(20) < 0.9  # another frame's pose is not the reference's


@needs_g1
def test_g1_falls_are_its_own_links_on_the_ground(g1_env):
    from actors.envs.falls import allowed_contact_links
    from actors.envs.ground_facts import track_ground_facts
    from tests.conftest import load_clip

    g1 = character_named("g1")
    walk = track_ground_facts(g1_env.humanoid, g1_env.track)
    assert allowed_contact_links(walk, character=g1) == ("left_ankle_roll_link", "right_ankle_roll_link")
    cartwheel_env = ImitationEnv(load_clip("cartwheel"), EnvConfig(character="g1"), g1_env.humanoid)  # retargeted at load
    cartwheel = track_ground_facts(g1_env.humanoid, cartwheel_env.track)
    assert allowed_contact_links(cartwheel, character=g1) == (
        "left_ankle_roll_link", "right_ankle_roll_link", "left_wrist_yaw_link", "right_wrist_yaw_link")
    env = g1_env
    env.reset(options={"init": "fsi"})
    env.data.qpos[2] = 0.1  # dropped to the floor: the thighs and knees land on it
    env.step(np.zeros(29))
    touching = env.fall_detector.touching(env.data)
    links = {g1.link_names[i] for i in range(g1.num_links) if touching >> i & 1}
    assert env.core.fell[0] and links and not links & set(g1.feet)
    assert "left_knee_link" in links


@needs_g1
def test_vector_env_retargets_a_humanoid_clip_once_and_steps_the_g1(walk_clip, caplog):
    starts = BufferedStarts(ReferenceStarts("rsi", np.random.default_rng(0)))
    with caplog.at_level("WARNING", logger="sfv.motion"):
        venv = VectorImitationEnv(walk_clip, G1, 3, starts, seed=1)
    assert sum("retargeted onto the g1" in r.getMessage() for r in caplog.records) == 1
    assert all(env.humanoid is venv.envs[0].humanoid and env.model.nu == 29 for env in venv.envs)
    venv.reset()
    rng = np.random.default_rng(0)
    for _ in range(40):  # long enough for episodes to end and restart
        obs, rewards, terminated, truncated, _ = venv.step(rng.uniform(-1, 1, (3, 29)))
        assert obs.shape == (3, 406) and np.isfinite(obs).all() and np.all((rewards >= 0) & (rewards <= 1))
    episodes = venv.episodes.drain()
    assert len(episodes["returns"]) > 0 and episodes["initial_states"].shape[1] == 68


@needs_g1
def test_g1_full_residual_action_reaches_each_motors_effort_at_rest(g1_walk):
    """With the per-joint range (the default), +-1 held from a reference start drives the hips'
    and knees' PD torque to their effort limits; with 0.5 rad on every joint it reaches a
    quarter to a half of them (kp 40-99 N m/rad against 88-139 N m)."""
    import mujoco

    from actors.motion.character_reference import load_reference

    reference = load_reference(str(g1_walk[1]), character_named("g1"))
    legs = [i for i, n in enumerate(character_named("g1").joint_names) if "hip_pitch" in n or "knee" in n]
    reach = {}
    for per_joint in (True, False):
        env = ImitationEnv(reference, EnvConfig(character="g1", horizon_s=1.0, residual_scale_per_joint=per_joint))
        env.reset(seed=0, options={"init": "rsi", "phase": 0.0})
        env.data.qvel[:] = 0.0  # at rest: the PD torque is kp x (target - angle), clipped to the effort
        action = np.zeros(29)
        lower, upper = env.humanoid.character.joint_limits[legs].T
        angle = env.data.qpos[7:][legs]
        action[legs] = np.where(upper - angle > angle - lower, 1.0, -1.0)  # towards the farther limit: no clipping
        env.actions.targets(action, out=env.data.ctrl[:29], base=env.track.ctrl[0])
        mujoco.mj_forward(env.model, env.data)
        torque = np.abs(env.data.actuator_force[legs])
        reach[per_joint] = torque / env.humanoid.character.torque_limits[legs]
    assert reach[True].min() > 0.95  # saturated: the whole effort is within the policy's reach
    assert reach[False].max() < 0.7
