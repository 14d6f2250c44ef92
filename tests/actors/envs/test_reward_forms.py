"""The imitation reward's two forms, checked against numbers computed here by hand.

- "deepmimic" (the default, DeepMimic's `SceneImitate::CalcRewardImitate`): five terms
  (pose, velocity, end effector, root, centre-of-mass velocity) weighted .5/.05/.15/.2/.1;
  joint errors are weighted means with DeepMimic's per-joint weights over their sum, the
  end-effector error is the mean over the four end effectors.
- "sfv_paper" (`RewardConfig.sfv_paper()`): SFV §7.2 as printed, plain sums over joints and
  end effectors, centre-of-mass position, no root term (weight 0).

Every expected number below comes from the edit the test makes to the reference state, the
scales and the weight table written out in this file, not from the reward module.
"""
import mujoco
import numpy as np
import pytest

from actors.character import quaternion as qn
from actors.character.features import RewardFeatures, update_kinematics
from actors.character.humanoid3d import Humanoid
from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.envs.modes.sfv.config import SfvConfig
from actors.envs.modes.sfv.reward import ImitationReward, RewardConfig
from actors.character.skeleton import END_EFFECTOR_LINKS, JOINT_IS_SPHERICAL, JOINT_NAMES
from tests.actors.envs.test_imitation_env import dof_index, qpos_index, terms_after  # noqa: F401  (helpers, not tests)

Z = np.array([0.0, 0.0, 1.0])
# DeepMimic's humanoid3d.txt DiffWeight per joint; the welded wrists have 0.
DIFF_WEIGHT = {"root": 1.0, "chest": 0.5, "neck": 0.3, "right_hip": 0.5, "right_knee": 0.3, "right_ankle": 0.2,
               "right_shoulder": 0.3, "right_elbow": 0.2, "right_wrist": 0.0, "left_hip": 0.5, "left_knee": 0.3,
               "left_ankle": 0.2, "left_shoulder": 0.3, "left_elbow": 0.2, "left_wrist": 0.0}
WEIGHT_SUM = 4.8
DEEPMIMIC_W = np.array([0.5, 0.05, 0.15, 0.2, 0.1])
PAPER_W = np.array([0.65, 0.1, 0.15, 0.0, 0.1])
FORMS = ("deepmimic", "sfv_paper")


def w(joint: str) -> float:
    """DeepMimic's normalised weight of one joint."""
    return DIFF_WEIGHT[joint] / WEIGHT_SUM


@pytest.fixture(scope="module")
def walk(walk_clip):
    return walk_clip


@pytest.fixture(scope="module")
def envs(walk):
    humanoid = Humanoid()
    return {"deepmimic": ImitationEnv(walk, EnvConfig(horizon_s=2.0), humanoid),
            "sfv_paper": ImitationEnv(walk, EnvConfig(horizon_s=2.0, sfv=SfvConfig(reward=RewardConfig.sfv_paper())), humanoid)}




def com_velocity(model, qpos, qvel, h=1e-6):
    """The centre of mass's world velocity by central differences of its position (MuJoCo's
    subtree_com after integrating qpos by +-h qvel): independent of mj_subtreeVel."""
    data = mujoco.MjData(model)

    def com(sign):
        q = qpos.copy()
        mujoco.mj_integratePos(model, q, qvel, sign * h)
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        return data.subtree_com[1].copy()

    return (com(1.0) - com(-1.0)) / (2.0 * h)


def com_term_deepmimic(env, row, edit):
    """exp(-10 * 0.1 |v_com - v_com_ref|^2) from finite-difference COM velocities."""
    env.set_reference_state(row)
    ref = com_velocity(env.model, env.data.qpos.copy(), env.data.qvel.copy())
    edit(env.data)
    sim = com_velocity(env.model, env.data.qpos.copy(), env.data.qvel.copy())
    return float(np.exp(-10.0 * 0.1 * np.sum((sim - ref) ** 2)))


# ------------------------------------------------------------------ perfect tracking
@pytest.mark.parametrize("form", FORMS)
def test_perfect_tracking_gives_one_and_every_term_one(envs, form):
    env = envs[form]
    for row in (0, 7, 20, env.track.start_steps - 1, env.track.rows - 1):
        env.set_reference_state(row)
        assert env.reward_at(row) == pytest.approx(1.0, abs=1e-9)
        assert env.reward_terms.shape == (5,)
        np.testing.assert_allclose(env.reward_terms, 1.0, atol=1e-9)


@pytest.mark.parametrize("form", FORMS)
def test_reward_is_the_weighted_sum_of_the_terms(envs, form):
    env = envs[form]
    weights = DEEPMIMIC_W if form == "deepmimic" else PAPER_W
    assert env.max_reward == pytest.approx(1.0)
    env.set_reference_state(5)
    reward = env.reward_at(15)  # the wrong frame: every term below 1
    assert reward < 0.9
    assert reward == pytest.approx(float(weights @ env.reward_terms), rel=1e-12)


def test_unknown_form_is_refused():
    with pytest.raises(ValueError, match="reward form"):
        RewardConfig(form="sum")


# ------------------------------------------------------------------------------ pose
def turn_every_joint(env, angle):
    """Turn the root (world) and every joint (local) by `angle`, each about its own axis."""
    rng = np.random.default_rng(4)

    def edit(data):
        axis = rng.normal(size=3)
        data.qpos[3:7] = qn.quat_mul(qn.quat_from_axis_angle(angle * axis / np.linalg.norm(axis)), data.qpos[3:7])
        for joint, spherical in zip(JOINT_NAMES, JOINT_IS_SPHERICAL):
            i = qpos_index(env, joint)
            if spherical:
                axis = rng.normal(size=3)
                data.qpos[i:i + 4] = qn.quat_mul(data.qpos[i:i + 4], qn.quat_from_axis_angle(angle * axis / np.linalg.norm(axis)))
            else:
                data.qpos[i] += angle

    return edit


def test_every_joint_off_by_0_3_rad_weighted_mean_against_sum(envs):
    """The issue's numbers: 0.3 rad on the root and all 12 joints."""
    angle = 0.3
    _, dm = terms_after(envs["deepmimic"], 10, turn_every_joint(envs["deepmimic"], angle))
    _, paper = terms_after(envs["sfv_paper"], 10, turn_every_joint(envs["sfv_paper"], angle))
    # DeepMimic: sum_j w_j * 0.09 / sum_j w_j = 0.09, the wrists (weight 0) adding nothing.
    mean_error = sum(DIFF_WEIGHT[j] * angle**2 for j in ["root", *JOINT_NAMES]) / WEIGHT_SUM
    assert mean_error == pytest.approx(0.09)
    assert dm[0] == pytest.approx(np.exp(-2.0 * mean_error), rel=1e-9)
    assert dm[0] == pytest.approx(0.8353, abs=1e-4)
    # The paper: the plain sum over 13 rotations, 13 * 0.09 = 1.17.
    assert paper[0] == pytest.approx(np.exp(-2.0 * 13 * angle**2), rel=1e-9)
    assert paper[0] == pytest.approx(0.0963, abs=1e-4)


@pytest.mark.parametrize("joint", JOINT_NAMES)
def test_one_joint_off_weighs_by_deepmimics_joint_weight(envs, joint):
    angle, row = 0.3, 12
    spherical = JOINT_IS_SPHERICAL[JOINT_NAMES.index(joint)]

    def edit_for(env):
        i = qpos_index(env, joint)

        def edit(data):
            if spherical:
                data.qpos[i:i + 4] = qn.quat_mul(data.qpos[i:i + 4], qn.quat_from_axis_angle(angle * np.array([0.6, 0.0, 0.8])))
            else:
                data.qpos[i] += angle
        return edit

    _, dm = terms_after(envs["deepmimic"], row, edit_for(envs["deepmimic"]))
    _, paper = terms_after(envs["sfv_paper"], row, edit_for(envs["sfv_paper"]))
    assert dm[0] == pytest.approx(np.exp(-2.0 * w(joint) * angle**2), rel=1e-9)
    assert paper[0] == pytest.approx(np.exp(-2.0 * angle**2), rel=1e-9)
    # A posture change moves no root: the root and velocity terms stay at 1.
    np.testing.assert_allclose(dm[[1, 3]], 1.0, atol=1e-12)
    np.testing.assert_allclose(paper[[1, 3]], 1.0, atol=1e-12)


def test_root_yaw_weighs_by_the_root_weight_and_enters_the_root_term(envs):
    row, yaw = 14, 0.4

    def turn(data):
        data.qpos[3:7] = qn.quat_mul(qn.quat_about_axis(yaw, Z), data.qpos[3:7])

    _, (pose, vel, ee, root, com) = terms_after(envs["deepmimic"], row, turn)
    assert pose == pytest.approx(np.exp(-2.0 * w("root") * yaw**2), rel=1e-9)
    # Root: position and world linear velocity unchanged, local angular velocity unchanged.
    assert root == pytest.approx(np.exp(-5.0 * 0.1 * yaw**2), rel=1e-9)
    assert vel == pytest.approx(1.0, abs=1e-12) and ee == pytest.approx(1.0, abs=1e-12)  # heading frame
    assert com == pytest.approx(com_term_deepmimic(envs["deepmimic"], row, turn), rel=1e-6)
    _, (pose, vel, ee, root, com) = terms_after(envs["sfv_paper"], row, turn)
    assert pose == pytest.approx(np.exp(-2.0 * yaw**2), rel=1e-9)
    assert (vel, ee, root) == pytest.approx((1.0, 1.0, 1.0), abs=1e-12)


# -------------------------------------------------------------------------- velocity
@pytest.mark.parametrize("joint", JOINT_NAMES)
def test_one_joint_velocity_error_weighs_by_deepmimics_joint_weight(envs, joint):
    """Each of the joint's qvel coordinates (MuJoCo's dof address) carries the joint's weight."""
    row, rate = 9, 1.5
    k = JOINT_NAMES.index(joint)
    dofs = 3 if JOINT_IS_SPHERICAL[k] else 1
    got = []
    for axis in range(dofs):
        def spin(data, axis=axis):
            data.qvel[dof_index(envs["deepmimic"], joint) + axis] += rate

        _, (pose, vel, *_) = terms_after(envs["deepmimic"], row, spin)
        assert pose == pytest.approx(1.0, abs=1e-12)
        got.append(-np.log(vel) / (0.1 * rate**2))  # the weight this coordinate carries
        _, (_, paper_vel, *_) = terms_after(envs["sfv_paper"], row, spin)
        assert paper_vel == pytest.approx(np.exp(-0.1 * rate**2), rel=1e-9)
    np.testing.assert_allclose(got, w(joint), rtol=1e-9, err_msg=f"velocity weight of {joint} (x{WEIGHT_SUM}: {np.round(np.array(got) * WEIGHT_SUM, 3)})")


def test_joint_velocity_error_lowers_velocity_and_com_terms(envs):
    row, chest_rate = 9, np.array([0.5, -1.0, 2.0])

    def spin_for(env):
        chest = dof_index(env, "chest")

        def spin(data):
            data.qvel[chest:chest + 3] += chest_rate
        return spin

    env = envs["deepmimic"]
    _, (pose, vel, ee, root, com) = terms_after(env, row, spin_for(env))
    assert vel == pytest.approx(np.exp(-0.1 * w("chest") * chest_rate @ chest_rate), rel=1e-9)
    assert (pose, ee, root) == pytest.approx((1.0, 1.0, 1.0), abs=1e-12)
    # A turning torso moves the centre of mass: the COM-velocity term sees it.
    expected_com = com_term_deepmimic(env, row, spin_for(env))
    assert expected_com < 0.999
    assert com == pytest.approx(expected_com, rel=1e-6)

    env = envs["sfv_paper"]
    _, (pose, vel, ee, root, com) = terms_after(env, row, spin_for(env))
    assert vel == pytest.approx(np.exp(-0.1 * chest_rate @ chest_rate), rel=1e-9)
    assert (pose, ee, root, com) == pytest.approx((1.0, 1.0, 1.0, 1.0), abs=1e-12)  # COM position unchanged


def test_root_linear_velocity_error_lowers_only_root_and_com_terms(envs):
    row, push = 11, np.array([0.4, -0.3, 0.2])

    def shove(data):
        data.qvel[:3] += push  # world frame: every body moves by `push`, so does the COM

    _, (pose, vel, ee, root, com) = terms_after(envs["deepmimic"], row, shove)
    assert root == pytest.approx(np.exp(-5.0 * 0.01 * push @ push), rel=1e-9)
    assert com == pytest.approx(np.exp(-10.0 * 0.1 * push @ push), rel=1e-9)
    assert (pose, vel, ee) == pytest.approx((1.0, 1.0, 1.0), abs=1e-12)
    # The paper's reward has no linear velocity at all.
    reward, terms = terms_after(envs["sfv_paper"], row, shove)
    assert reward == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(terms, 1.0, atol=1e-12)


def test_root_angular_velocity_enters_velocity_and_root_terms(envs):
    row, spin = 8, np.array([0.0, 0.0, 2.0])

    def twist(data):
        data.qvel[3:6] += spin

    env = envs["deepmimic"]
    _, (pose, vel, ee, root, com) = terms_after(env, row, twist)
    assert vel == pytest.approx(np.exp(-0.1 * w("root") * spin @ spin), rel=1e-9)
    assert root == pytest.approx(np.exp(-5.0 * 0.001 * spin @ spin), rel=1e-9)
    assert (pose, ee) == pytest.approx((1.0, 1.0), abs=1e-12)
    assert com == pytest.approx(com_term_deepmimic(env, row, twist), rel=1e-6)


# ---------------------------------------------------------------- root translation
def test_horizontal_root_offset_lowers_the_root_term_only(envs):
    row, shift = 11, np.array([0.1, -0.2, 0.0])

    def move(data):
        data.qpos[:3] += shift

    _, (pose, vel, ee, root, com) = terms_after(envs["deepmimic"], row, move)
    assert root == pytest.approx(np.exp(-5.0 * shift @ shift), rel=1e-9)
    # End effectors: horizontal offsets from the root and heights, both unchanged.
    assert (pose, vel, ee, com) == pytest.approx((1.0, 1.0, 1.0, 1.0), abs=1e-12)
    _, (pose, vel, ee, root, com) = terms_after(envs["sfv_paper"], row, move)
    assert com == pytest.approx(np.exp(-10.0 * shift @ shift), rel=1e-9)  # COM position
    assert (pose, vel, ee, root) == pytest.approx((1.0, 1.0, 1.0, 1.0), abs=1e-12)


def test_vertical_root_offset_lowers_root_and_end_effector_heights(envs):
    row, dz = 11, 0.05

    def lift(data):
        data.qpos[2] += dz

    _, (pose, vel, ee, root, com) = terms_after(envs["deepmimic"], row, lift)
    assert root == pytest.approx(np.exp(-5.0 * dz**2), rel=1e-9)
    assert ee == pytest.approx(np.exp(-40.0 * dz**2), rel=1e-9)  # mean over 4 of dz^2 each
    assert (pose, vel, com) == pytest.approx((1.0, 1.0, 1.0), abs=1e-12)
    _, (pose, vel, ee, root, com) = terms_after(envs["sfv_paper"], row, lift)
    assert ee == pytest.approx(np.exp(-40.0 * 4 * dz**2), rel=1e-9)  # sum over the 4
    assert com == pytest.approx(np.exp(-10.0 * dz**2), rel=1e-9)


# ------------------------------------------------------------------- end effectors
def test_end_effector_features_are_deepmimics(envs):
    """Horizontal offset from the root in the heading frame, and height above the ground."""
    env = envs["deepmimic"]
    for row in (3, 30):
        env.set_reference_state(row)
        features = env.features.reward_features_of(env.data)
        root = env.data.qpos[:3]
        yaw = qn.heading_angle(env.data.qpos[3:7])
        c, s = np.cos(yaw), np.sin(yaw)
        for k, link in enumerate(END_EFFECTOR_LINKS):
            p = env.data.xpos[env.humanoid.body_ids[link]]
            dx, dy = p[:2] - root[:2]
            expected = [c * dx + s * dy, -s * dx + c * dy, p[2]]
            np.testing.assert_allclose(features.end_effectors[0, k], expected, atol=1e-12)
        com_vel = com_velocity(env.model, env.data.qpos.copy(), env.data.qvel.copy())
        np.testing.assert_allclose(features.com_vel[0], com_vel, atol=1e-6)


def test_elbow_bend_end_effector_error_is_a_mean_in_deepmimic_and_a_sum_in_the_paper(envs):
    delta, row = 0.3, 10

    def bend_for(env):
        elbow = qpos_index(env, "left_elbow")

        def bend(data):
            data.qpos[elbow] += delta
        return bend

    env = envs["deepmimic"]
    env.set_reference_state(row)
    wrist = env.humanoid.body_ids[END_EFFECTOR_LINKS[3]]  # left wrist
    before = env.data.xpos[wrist].copy()
    bend_for(env)(env.data)
    update_kinematics(env.model, env.data)
    moved = env.data.xpos[wrist] - before  # the heading frame keeps lengths; the ankles stay
    assert moved @ moved > 1e-3
    _, (pose, vel, ee, root, com) = terms_after(env, row, bend_for(env))
    assert pose == pytest.approx(np.exp(-2.0 * w("left_elbow") * delta**2), rel=1e-9)
    assert ee == pytest.approx(np.exp(-40.0 * (moved @ moved) / 4.0), rel=1e-9)
    assert root == pytest.approx(1.0, abs=1e-12) and vel == pytest.approx(1.0, abs=1e-12)
    assert com == pytest.approx(com_term_deepmimic(env, row, bend_for(env)), rel=1e-6)
    _, (pose, vel, ee, root, com) = terms_after(envs["sfv_paper"], row, bend_for(envs["sfv_paper"]))
    assert ee == pytest.approx(np.exp(-40.0 * (moved @ moved)), rel=1e-9)
    assert pose == pytest.approx(np.exp(-2.0 * delta**2), rel=1e-9)


# ------------------------------------------------- feature level: COM velocity vs position
def reward_of_edited_features(track, row, config, edit):
    ref = track.reward_features(row)
    sim = RewardFeatures(ref.values.copy())
    edit(sim)
    terms = np.zeros(5)
    return ImitationReward(config)(sim, ref, terms), terms


def test_com_velocity_error_lowers_only_the_com_term_in_deepmimic_form(envs):
    track, dv = envs["deepmimic"].track, np.array([0.3, 0.0, -0.4])

    def edit(sim):
        sim.com_vel[0] += dv

    reward, terms = reward_of_edited_features(track, 17, RewardConfig(), edit)
    np.testing.assert_allclose(terms[:4], 1.0, atol=1e-12)
    assert terms[4] == pytest.approx(np.exp(-10.0 * 0.1 * dv @ dv), rel=1e-12)
    assert reward == pytest.approx(0.9 + 0.1 * terms[4], rel=1e-12)
    # The paper's COM term is the position: a velocity error costs nothing there.
    reward, terms = reward_of_edited_features(track, 17, RewardConfig.sfv_paper(), edit)
    assert reward == pytest.approx(1.0, abs=1e-12)


def test_com_position_error_lowers_only_the_papers_com_term(envs):
    track, dc = envs["deepmimic"].track, np.array([0.1, 0.2, 0.0])

    def edit(sim):
        sim.com[0] += dc

    reward, _ = reward_of_edited_features(track, 17, RewardConfig(), edit)
    assert reward == pytest.approx(1.0, abs=1e-12)
    reward, terms = reward_of_edited_features(track, 17, RewardConfig.sfv_paper(), edit)
    assert terms[4] == pytest.approx(np.exp(-10.0 * dc @ dc), rel=1e-12)
    np.testing.assert_allclose(terms[:4], 1.0, atol=1e-12)


def test_batch_of_rewards_matches_rows_one_at_a_time(envs):
    """The batched reward (the vector env's path) equals the per-row reward."""
    track = envs["deepmimic"].track
    rows = np.array([0, 5, 9, 23])
    sim = track.features.take(rows + 3)  # each scored against a frame 0.1 s off
    ref = track.features.take(rows)
    for config in (RewardConfig(), RewardConfig.sfv_paper()):
        reward = ImitationReward(config)
        terms = np.zeros((len(rows), 5))
        batch = reward.batch(sim, ref, terms).copy()
        for k in range(len(rows)):
            one = np.zeros(5)
            assert reward(sim.slice(slice(k, k + 1)), ref.slice(slice(k, k + 1)), one) == pytest.approx(batch[k], rel=1e-12)
            np.testing.assert_allclose(one, terms[k], rtol=1e-12)
        assert (batch < 0.95).all()
