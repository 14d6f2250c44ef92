"""The imitation env with real MuJoCo: reward terms in the paper's form (SFV §7.2,
`RewardConfig.sfv_paper()`; the default DeepMimic form is in test_reward_forms.py),
termination, truncation, initial states, determinism, observation and action spaces."""

import mujoco
import numpy as np
import pytest

from actors.character import quaternion as qn
from actors.character.actions import ActionMapper
from actors.character.features import update_kinematics
from actors.character.humanoid3d import Humanoid
from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.envs.modes.sfv.config import SfvConfig
from actors.character.kinematics import forward_kinematics
from actors.envs.modes.sfv.reward import RewardConfig
from actors.character.skeleton import END_EFFECTOR_LINKS, JOINT_NAMES, LINK_NAMES, NUM_JOINTS
from actors.character.state import StateLayout

Z = np.array([0.0, 0.0, 1.0])


@pytest.fixture(scope="module")
def walk():
    pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")
    from actors.motion.formats.io import load_motion

    return load_motion("deepmimic:walk")


@pytest.fixture(scope="module")
def kick():
    pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")
    from actors.motion.formats.io import load_motion

    return load_motion("deepmimic:kick")


@pytest.fixture(scope="module")
def humanoid():
    return Humanoid()


@pytest.fixture(scope="module")
def env(walk, humanoid):
    return ImitationEnv(walk, EnvConfig(horizon_s=2.0), humanoid)


@pytest.fixture(scope="module")
def paper_env(walk, humanoid):
    """The paper's reward: sums over joints, four terms (the root term's weight is 0)."""
    return ImitationEnv(walk, EnvConfig(horizon_s=2.0, sfv=SfvConfig(reward=RewardConfig.sfv_paper())), humanoid)


@pytest.fixture
def scratch_cwd(tmp_path, monkeypatch):
    """MuJoCo writes MUJOCO_LOG.TXT into the working directory on a simulation warning."""
    monkeypatch.chdir(tmp_path)


def qpos_index(env, joint_name):
    return env.humanoid.joint_qpos_adr[JOINT_NAMES.index(joint_name)]


def dof_index(env, joint_name):
    return env.humanoid.joint_dof_adr[JOINT_NAMES.index(joint_name)]


def terms_after(env, row, edit):
    """Reward terms with the character on the reference at `row`, then edited by `edit(data)`."""
    env.set_reference_state(row)
    edit(env.data)
    update_kinematics(env.model, env.data)
    reward = env.reward_at(row)
    return reward, env.reward_terms.copy()


# --------------------------------------------------------------------------- reward
def test_perfect_tracking_scores_exactly_one(env):
    for row in (0, 7, 20, env.track.start_steps - 1, env.track.rows - 1):
        env.set_reference_state(row)
        assert env.reward_at(row) == pytest.approx(1.0, abs=1e-9)
        np.testing.assert_allclose(env.reward_terms, 1.0, atol=1e-9)


def test_tracking_the_wrong_frame_scores_less(env):
    env.set_reference_state(5)
    assert env.reward_at(15) < 0.9


def test_hinge_error_lowers_pose_and_end_effector_terms(paper_env):
    env = paper_env
    delta, row = 0.3, 10
    elbow = qpos_index(env, "left_elbow")
    reference_pose = env.track.qpos[row].copy()

    def bend(data):
        data.qpos[elbow] += delta

    reward, (pose, vel, ee, root, com) = terms_after(env, row, bend)
    assert pose == pytest.approx(np.exp(-2.0 * delta**2), rel=1e-9)  # one rotation off by delta
    assert vel == pytest.approx(1.0, abs=1e-12) and root == pytest.approx(1.0, abs=1e-12)
    # Independent check of the end-effector term: the wrist moves, the ankles do not, and a
    # heading-frame rotation keeps lengths, so the error is the wrist's world displacement.
    layout, quats = StateLayout(env.humanoid), np.zeros((NUM_JOINTS, 4))
    moved = reference_pose.copy()
    moved[elbow] += delta
    wrist = LINK_NAMES.index("left_wrist")
    before = forward_kinematics(reference_pose[:3], reference_pose[3:7], layout.joint_quats_from_qpos(reference_pose, quats.copy()))[0][wrist]
    after = forward_kinematics(moved[:3], moved[3:7], layout.joint_quats_from_qpos(moved, quats.copy()))[0][wrist]
    assert ee == pytest.approx(np.exp(-40.0 * np.sum((after - before) ** 2)), rel=1e-9) and ee < 0.99
    assert com < 1.0
    assert reward == pytest.approx(0.65 * pose + 0.1 * vel + 0.15 * ee + 0.1 * com, rel=1e-12)


def test_ball_joint_error_lowers_only_pose_and_com_terms(paper_env):
    env = paper_env
    angle, row = 0.25, 12
    neck = qpos_index(env, "neck")
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])

    def turn_head(data):
        data.qpos[neck:neck + 4] = qn.quat_mul(data.qpos[neck:neck + 4], qn.quat_from_axis_angle(angle * axis))

    _, (pose, vel, ee, root, com) = terms_after(env, row, turn_head)
    assert pose == pytest.approx(np.exp(-2.0 * angle**2), rel=1e-9)
    assert vel == pytest.approx(1.0, abs=1e-12) and ee == pytest.approx(1.0, abs=1e-12)  # the head is no end effector
    assert com < 1.0


def test_velocity_error_lowers_only_velocity_term(paper_env):
    env = paper_env
    row, kick_rate = 9, np.array([0.5, -1.0, 2.0])
    chest = dof_index(env, "chest")
    knee = dof_index(env, "right_knee")

    def spin(data):
        data.qvel[chest:chest + 3] += kick_rate
        data.qvel[knee] += 1.5

    _, (pose, vel, ee, root, com) = terms_after(env, row, spin)
    assert vel == pytest.approx(np.exp(-0.1 * (kick_rate @ kick_rate + 1.5**2)), rel=1e-9)
    np.testing.assert_allclose((pose, ee, root, com), 1.0, atol=1e-12)


def test_root_translation_lowers_com_and_end_effector_height_terms(paper_env):
    env, row, shift = paper_env, 11, np.array([0.1, -0.2, 0.05])

    def move(data):
        data.qpos[:3] += shift

    _, (pose, vel, ee, root, com) = terms_after(env, row, move)
    assert com == pytest.approx(np.exp(-10.0 * shift @ shift), rel=1e-9)
    # End effectors are DeepMimic's features in both forms: horizontal offsets from the root
    # (unchanged) and heights above the ground (each of the 4 up by shift[2], summed).
    assert ee == pytest.approx(np.exp(-40.0 * 4 * shift[2] ** 2), rel=1e-9)
    np.testing.assert_allclose((pose, vel, root), 1.0, atol=1e-12)


def test_root_yaw_changes_pose_but_not_heading_frame_end_effectors(paper_env):
    env = paper_env
    row, yaw = 14, 0.4

    def turn(data):
        data.qpos[3:7] = qn.quat_mul(qn.quat_about_axis(yaw, Z), data.qpos[3:7])

    _, (pose, vel, ee, root, com) = terms_after(env, row, turn)
    assert pose == pytest.approx(np.exp(-2.0 * yaw**2), rel=1e-9)
    assert ee == pytest.approx(1.0, abs=1e-12) and vel == pytest.approx(1.0, abs=1e-12)


# ---------------------------------------------------------------------- observation
def test_observation_shape_range_and_phase(env):
    obs, info = env.reset(seed=3)
    # 197 state features of SFV, then 2 reference roots x (3 + 4) before the phase.
    assert env.observation_space.shape == (211,) and obs.shape == (211,) and obs.dtype == np.float32
    assert np.isfinite(obs).all()
    assert obs[-1] == pytest.approx(info["phase"]) and 0.0 <= obs[-1] <= 1.0
    assert obs[0] == pytest.approx(env.data.qpos[2], abs=1e-6)  # root height
    rng = np.random.default_rng(0)
    for _ in range(5):
        obs, *_ = env.step(rng.uniform(-1, 1, env.action_space.shape))
        assert np.isfinite(obs).all() and 0.0 <= obs[-1] <= 1.0
        assert obs[-1] == pytest.approx(env.phase)


def test_observation_is_invariant_to_heading_and_horizontal_position(env):
    """Features live in the character's heading frame: turning and moving the whole
    character on the floor leaves the observation unchanged."""
    row, yaw, shift = 17, 1.1, np.array([2.0, -3.0, 0.0])
    env.reset(seed=0, options={"init": "fsi"})
    env.set_reference_state(row)
    before = env.features.observation(env.data, 0.5, np.zeros(197)).copy()
    turn = qn.quat_about_axis(yaw, Z)
    env.data.qpos[:3] = qn.quat_rotate(turn, env.data.qpos[:3]) + shift
    env.data.qpos[3:7] = qn.quat_mul(turn, env.data.qpos[3:7])
    env.data.qvel[:3] = qn.quat_rotate(turn, env.data.qvel[:3])  # world frame; angular ones are local
    update_kinematics(env.model, env.data)
    after = env.features.observation(env.data, 0.5, np.zeros(197))
    np.testing.assert_allclose(after, before, atol=1e-9)
    # A pitch is not a heading change: the observation must see it.
    env.data.qpos[3:7] = qn.quat_mul(env.data.qpos[3:7], qn.quat_about_axis(0.3, np.array([0.0, 1.0, 0.0])))
    update_kinematics(env.model, env.data)
    assert np.abs(env.features.observation(env.data, 0.5, np.zeros(197)) - before).max() > 0.05


def test_observation_shows_where_the_reference_root_is(env):
    """The reference roots 1 and 15 steps ahead, relative to the character's root in its
    heading frame: computed here from the track with quaternion maths, not the extractor's."""
    row = 9
    obs, _ = env.reset(seed=0, options={"init": "rsi", "phase": env.track.phase[row]})
    assert env.row == row
    root, rot = env.data.qpos[:3].copy(), env.data.qpos[3:7].copy()
    yaw = np.arctan2(2 * (rot[0] * rot[3] + rot[1] * rot[2]), 1 - 2 * (rot[2] ** 2 + rot[3] ** 2))
    inverse = qn.quat_about_axis(-yaw, Z)
    for i, k in enumerate((1, 15)):
        target = env.track.qpos[row + k]
        expected_pos = qn.quat_rotate(inverse, target[:3] - root)
        expected_rot = qn.quat_mul(inverse, target[3:7])
        expected_rot = expected_rot * np.sign(expected_rot[0])
        np.testing.assert_allclose(obs[196 + 3 * i:199 + 3 * i], expected_pos, atol=1e-5)
        np.testing.assert_allclose(obs[202 + 4 * i:206 + 4 * i], expected_rot, atol=1e-5)
    # 15 steps (0.5 s) of walking put the reference root ahead along the heading.
    assert obs[199] > 0.3 and abs(obs[200]) < 0.15


# ---------------------------------------------------------------- termination, horizon
def upside_down_state(env, height=1.0):
    mujoco.mj_resetData(env.model, env.data)
    qpos, qvel = env.data.qpos.copy(), np.zeros(env.model.nv)
    qpos[2] = height
    qpos[3:7] = [0.0, 1.0, 0.0, 0.0]  # 180 degrees about x: head down
    return env.layout.state_vector(qpos, qvel)


def head_or_torso_touches_floor(env):
    geoms = env.data.contact.geom[: env.data.ncon]
    return bool(np.isin(geoms, env.humanoid.fall_geom_ids).any(axis=1).any())


def _steps_to_termination(env, state):
    env.reset(seed=0, options={"phase": 0.0, "state": state})
    for step in range(1, 31):
        _, reward, terminated, truncated, _ = env.step(np.zeros(env.action_space.shape))
        if terminated:
            break
    return step, reward, terminated, truncated


def test_falls_on_head_end_the_episode(env, walk, humanoid):
    contact_only = ImitationEnv(walk, EnvConfig(horizon_s=2.0, sfv=SfvConfig(tracking_termination_m=0.0)), humanoid)
    step, reward, terminated, truncated = _steps_to_termination(contact_only, upside_down_state(contact_only))
    assert terminated and not truncated and step < 30
    assert head_or_torso_touches_floor(contact_only)
    assert reward == 0.0  # the step that ends in a fall earns nothing (DeepMimic)
    # The default tracking termination (1.0 m) ends the same start no later, also as a fall.
    deviated, reward, terminated, _ = _steps_to_termination(env, upside_down_state(env))
    assert terminated and deviated <= step and reward == 0.0


def test_without_early_termination_the_fall_goes_on(walk, humanoid):
    env = ImitationEnv(walk, EnvConfig(horizon_s=2.0, early_termination=False), humanoid)
    env.reset(seed=0, options={"phase": 0.0, "state": upside_down_state(env)})
    touched = False
    for _ in range(30):
        _, _, terminated, truncated, _ = env.step(np.zeros(env.action_space.shape))
        assert not terminated and not truncated
        touched |= head_or_torso_touches_floor(env)
    assert touched, "the head did reach the floor"


def test_feet_on_the_floor_do_not_end_the_episode(env):
    env.reset(seed=0, options={"init": "fsi"})
    _, reward, terminated, _, _ = env.step(np.zeros(env.action_space.shape))
    feet = [env.model.body_geomadr[env.humanoid.body_ids[LINK_NAMES.index(n)]] for n in ("right_ankle", "left_ankle")]
    touching = set(env.data.contact.geom[: env.data.ncon].ravel()) - {env.humanoid.floor_geom_id}
    assert env.data.ncon > 0 and touching <= set(feet)  # only the feet touch the floor
    assert not terminated and reward > 0.9


def test_diverged_simulation_is_terminated_not_teleported(env, scratch_cwd):
    state = env.reference_state_vector(5).copy()
    state[env.layout.nq - 2 + 6:] = 1e9  # absurd joint velocities: MuJoCo resets its data
    env.reset(seed=0, options={"phase": env.track.phase[5], "state": state})
    obs, reward, terminated, truncated, _ = env.step(np.zeros(env.action_space.shape))
    assert terminated and not truncated and reward == 0.0
    assert np.isfinite(obs).all()
    env.reset(seed=0)  # and the next episode is clean
    _, _, terminated, _, _ = env.step(np.zeros(env.action_space.shape))
    assert not terminated


def test_looped_clip_truncates_at_the_horizon(walk, humanoid):
    env = ImitationEnv(walk, EnvConfig(horizon_s=0.5, early_termination=False), humanoid)
    for phase in (0.0, 0.6):
        env.reset(seed=1, options={"phase": phase})
        assert env.max_episode_steps == 15
        flags = [env.step(np.zeros(env.action_space.shape))[3] for _ in range(15)]
        assert flags == [False] * 14 + [True]


def test_non_looped_clip_truncates_at_its_end(kick, humanoid):
    env = ImitationEnv(kick, EnvConfig(horizon_s=0.5, early_termination=False), humanoid)
    clip_steps = int(round(kick.duration * 30))
    for phase in (0.0, 0.5):
        _, info = env.reset(seed=0, options={"init": "rsi", "phase": phase})
        expected = clip_steps - info["start_step"]
        assert env.max_episode_steps == expected and expected > 15  # the horizon_s is for loops only
        for step in range(1, expected + 1):
            obs, _, terminated, truncated, _ = env.step(np.zeros(env.action_space.shape))
            assert truncated == (step == expected) and not terminated
        assert obs[-1] == pytest.approx(1.0)  # the clip's end


# ------------------------------------------------------------------- initial states
def test_fsi_starts_on_the_first_frame(walk, env):
    obs, info = env.reset(seed=5, options={"init": "fsi"})
    assert info["phase"] == 0.0 and info["start_step"] == 0 and obs[-1] == 0.0
    np.testing.assert_allclose(env.data.qpos[:3], walk.root_pos[0], atol=1e-12)
    assert np.abs(np.abs(env.data.qpos[3:7] @ walk.root_rot[0]) - 1.0) < 1e-12
    joints = env.layout.joint_quats_from_qpos(env.data.qpos, np.zeros((NUM_JOINTS, 4)))
    np.testing.assert_allclose(np.abs(np.sum(joints * walk.joint_rot[0], axis=-1)), 1.0, atol=1e-9)
    pose = walk.sample(0.0)
    np.testing.assert_allclose(env.track.reference_qvel[0, :3], pose.root_lin_vel, atol=1e-12)
    np.testing.assert_allclose(env.data.qvel, env.track.qvel[0], atol=1e-12)  # the start's: spikes filtered


def test_rsi_starts_at_different_phases_on_the_reference(env):
    phases = set()
    for seed in range(12):
        _, info = env.reset(seed=seed, options={"init": "rsi"})
        start = info["start_step"]
        assert 0 <= start < env.track.start_steps
        np.testing.assert_array_equal(env.state_vector(), env.reference_state_vector(start))
        phases.add(round(info["phase"], 6))
    assert len(phases) >= 6
    assert all(0.0 <= p < 1.0 for p in phases)


def test_given_state_start_reproduces_the_state(env):
    row = 10
    rng = np.random.default_rng(2)
    state = env.reference_state_vector(row) + rng.normal(scale=0.05, size=env.state_dim)
    for s in env.layout.state_quat_slices:
        state[s] *= 3.0  # not unit: the env normalises
    obs, info = env.reset(seed=0, options={"phase": env.track.phase[row], "state": state})
    assert info["start_step"] == row and obs[-1] == pytest.approx(env.track.phase[row])
    expected = state.copy()
    for s in env.layout.state_quat_slices:
        expected[s] /= np.linalg.norm(expected[s])
    np.testing.assert_allclose(env.state_vector(), expected, atol=1e-12)
    np.testing.assert_array_equal(env.data.qpos[:2], env.track.qpos[row, :2])  # root xy from the reference
    with pytest.raises(ValueError, match="initial state"):
        env.reset(options={"phase": 0.0, "state": state[:-1]})
    bad = state.copy()
    bad[3] = np.nan
    with pytest.raises(ValueError, match="initial state"):
        env.reset(options={"phase": 0.0, "state": bad})


def test_same_seed_and_actions_give_identical_trajectories(walk, humanoid):
    def rollout():
        env = ImitationEnv(walk, EnvConfig(horizon_s=1.0), humanoid)
        obs, info = env.reset(seed=42)
        rng = np.random.default_rng(7)
        trajectory = [obs]
        for _ in range(20):
            obs, reward, terminated, truncated, _ = env.step(rng.uniform(-1, 1, env.action_space.shape))
            trajectory.append(np.append(obs, [reward, terminated, truncated]))
            if terminated or truncated:
                break
        return info["start_step"], trajectory

    (start_a, a), (start_b, b) = rollout(), rollout()
    assert start_a == start_b and len(a) == len(b)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)


# --------------------------------------------------------------------------- actions
def test_action_spaces(walk, humanoid):
    # The default: exp-map residual actions, 8 ball joints x 3 + 4 hinges.
    env = ImitationEnv(walk, EnvConfig(horizon_s=0.5), humanoid)
    assert env.action_space.shape == (28,) and env.actions.residual
    assert (env.action_space.low == -1).all() and (env.action_space.high == 1).all()
    # SFV's axis-angle actions, 8 x (angle + axis) + 4 hinges, are absolute targets only.
    paper = ImitationEnv(walk, EnvConfig(horizon_s=0.5, action_parameterisation="axis_angle", residual_action_scale=None), humanoid)
    assert paper.action_space.shape == (36,) and not paper.actions.residual
    with pytest.raises(ValueError, match="residual"):
        ImitationEnv(walk, EnvConfig(horizon_s=0.5, action_parameterisation="axis_angle"), humanoid)
    with pytest.raises(ValueError, match="parameterisation"):
        ActionMapper("quaternion")


@pytest.mark.parametrize("parameterisation", ["axis_angle", "exp_map"])
def test_action_for_targets_inverts_targets(parameterisation):
    mapper = ActionMapper(parameterisation)
    rng = np.random.default_rng(9)
    for _ in range(50):
        targets = rng.uniform(mapper.lower, mapper.upper)
        rv = targets[:24].reshape(8, 3)
        too_far = np.linalg.norm(rv, axis=1) > 0.95 * np.pi  # the axis-angle action reaches angles up to pi
        rv[too_far] *= 0.95 * np.pi / np.linalg.norm(rv[too_far], axis=1, keepdims=True)
        action = mapper.action_for_targets(targets)
        assert action.shape == (mapper.action_dim,) and np.abs(action).max() <= 1.0 + 1e-12
        np.testing.assert_allclose(mapper.targets(action), targets, atol=1e-9)
    # Out-of-range actions are clipped to the box and the targets to the joint limits.
    wild = mapper.targets(rng.uniform(-5, 5, mapper.action_dim)).copy()
    assert (wild >= mapper.lower - 1e-12).all() and (wild <= mapper.upper + 1e-12).all()


def test_pd_targets_move_the_intended_joints(walk, humanoid):
    """End to end: an absolute action asking for a bent elbow and a raised shoulder gets them."""
    env = ImitationEnv(walk, EnvConfig(horizon_s=2.0, action_parameterisation="exp_map", residual_action_scale=None), humanoid)
    mujoco.mj_resetData(env.model, env.data)
    standing = env.layout.state_vector(env.data.qpos, env.data.qvel)
    env.reset(seed=0, options={"phase": 0.0, "state": standing})
    elbow_ctrl = 24 + [n for n in JOINT_NAMES if n.endswith(("knee", "elbow"))].index("right_elbow")
    shoulder = [n for n in JOINT_NAMES if not n.endswith(("knee", "elbow"))].index("left_shoulder")
    targets = np.zeros(28)
    targets[elbow_ctrl] = 1.2
    targets[3 * shoulder:3 * shoulder + 3] = [0.6, 0.0, 0.0]  # about the Z-up x axis: a sideways raise
    action = env.actions.action_for_targets(targets)
    for _ in range(20):
        _, _, terminated, _, _ = env.step(action)
        assert not terminated
    assert env.data.qpos[qpos_index(env, "right_elbow")] == pytest.approx(1.2, abs=0.05)
    shoulder_q = env.data.qpos[qpos_index(env, "left_shoulder"):qpos_index(env, "left_shoulder") + 4]
    np.testing.assert_allclose(qn.quat_to_axis_angle(shoulder_q), [0.6, 0.0, 0.0], atol=0.05)
    # The hand went where the forward kinematics says a raised arm puts it.
    wrist = env.data.xpos[env.humanoid.body_ids[LINK_NAMES.index("left_wrist")]]
    assert wrist[2] > env.data.xpos[env.humanoid.body_ids[END_EFFECTOR_LINKS[0]]][2] + 0.3
