"""Residual exp-map actions (the default): PD target = the reference's target at the row the
step acts towards + 0.5 rad x the clipped action, then clipped to the joint limits; and the
absolute maps (`residual_action_scale=None`) as they were.

Expected targets are built here from the reference's quaternions and the skeleton's limits.
"""
import numpy as np
import pytest

from actors.character import quaternion as qn
from actors.character.actions import ActionMapper
from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.envs.initial_states import BufferedStarts, ReferenceStarts
from actors.character.skeleton import JOINT_IS_SPHERICAL, JOINT_LINKS, JOINT_NAMES, LINKS, joint_limits_zup
from actors.envs.vector_env import VectorImitationEnv

BALL = [n for n, s in zip(JOINT_NAMES, JOINT_IS_SPHERICAL) if s]
HINGE = [n for n, s in zip(JOINT_NAMES, JOINT_IS_SPHERICAL) if not s]
LIMITS = np.concatenate([joint_limits_zup(LINKS[JOINT_LINKS[JOINT_NAMES.index(n)]]) for n in BALL + HINGE])  # (28, 2)
LOWER, UPPER = LIMITS[:, 0], LIMITS[:, 1]
SCALE = 0.5  # EnvConfig's default residual scale, rad


def ctrl_index(joint, axis=0):
    """Column of a joint's PD target: 3 per ball joint, then one per hinge."""
    return 3 * BALL.index(joint) + axis if joint in BALL else 24 + HINGE.index(joint)


@pytest.fixture(scope="module")
def walk(walk_clip):
    return walk_clip


@pytest.fixture(scope="module")
def humanoid(shared_humanoid):
    return shared_humanoid


@pytest.fixture(scope="module")
def env(walk, humanoid):
    return ImitationEnv(walk, EnvConfig(horizon_s=2.0), humanoid)


def reference_targets(env, row):
    """The reference pose as PD targets: ball joints' rotation vectors, hinge angles."""
    qpos = env.track.qpos[row]
    adr = {n: env.humanoid.joint_qpos_adr[JOINT_NAMES.index(n)] for n in JOINT_NAMES}
    balls = [qn.quat_to_axis_angle(qpos[adr[n]:adr[n] + 4]) for n in BALL]
    return np.concatenate(balls + [[qpos[adr[n]] for n in HINGE]])


# ------------------------------------------------------------------ reference targets
def test_reference_targets_are_the_reference_pose(env):
    for row in (0, 11, 37, env.track.rows - 1):
        np.testing.assert_allclose(env.track.ctrl[row], reference_targets(env, row), atol=1e-9)
    assert np.abs(np.diff(env.track.ctrl, axis=0)).max() > 0.01  # the targets follow the clip


def test_zero_action_targets_the_reference_the_lead_after_the_next_row(env):
    assert env.action_space.shape == (28,) and env.actions.residual
    lead = env.target_lead_steps
    assert lead == round(env.config.target_lead_s * env.config.control_hz) == 2  # the default: 1/15 s at 30 Hz
    for phase in (0.0, 0.3, 0.8):
        _, info = env.reset(seed=0, options={"phase": phase})
        row = info["start_step"]
        for k in range(3):
            env.step(np.zeros(28))
            expected = np.clip(reference_targets(env, row + k + 1 + lead), LOWER, UPPER)
            np.testing.assert_allclose(env.data.ctrl, expected, atol=1e-9)
            assert np.abs(env.data.ctrl - reference_targets(env, row + k + 1)).max() > 1e-3  # not the next row's


def test_lead_zero_targets_the_next_row_and_the_lead_stops_at_the_tables_end(walk, humanoid):
    env = ImitationEnv(walk, EnvConfig(horizon_s=2.0, target_lead_s=0.0), humanoid)
    _, info = env.reset(seed=0, options={"phase": 0.5})
    env.step(np.zeros(28))
    np.testing.assert_allclose(env.data.ctrl, np.clip(reference_targets(env, info["start_step"] + 1), LOWER, UPPER), atol=1e-9)
    led = ImitationEnv(walk, EnvConfig(horizon_s=2.0), humanoid)
    last = led.track.rows - 1
    np.testing.assert_array_equal(led.reference_targets(last - 1), led.track.ctrl[last:last + 1])
    with pytest.raises(ValueError, match="target_lead_s"):
        EnvConfig(target_lead_s=-0.1)


def test_vector_env_adds_each_envs_own_reference_row(walk):
    starts = BufferedStarts(ReferenceStarts("rsi", np.random.default_rng(5)), batch=3)
    venv = VectorImitationEnv(walk, EnvConfig(horizon_s=1.0), num_envs=3, starts=starts, seed=3)
    venv.reset()
    rows = [env.row for env in venv.envs]
    assert len(set(rows)) >= 2
    action = np.zeros((3, venv.action_dim))
    action[:, ctrl_index("left_knee")] = -1.0  # bend further by 0.5 rad
    venv.step(action)
    for env, row in zip(venv.envs, rows):
        expected = reference_targets(env, row + 1 + env.target_lead_steps)
        expected[ctrl_index("left_knee")] -= SCALE
        np.testing.assert_allclose(env.data.ctrl, np.clip(expected, LOWER, UPPER), atol=1e-9)


# ---------------------------------------------------------------------- the mapping
def test_residual_map_adds_half_a_radian_per_unit_and_clips():
    mapper = ActionMapper("exp_map", SCALE)
    rng = np.random.default_rng(0)
    base = rng.uniform(LOWER, UPPER, size=(6, 28))
    base[0] = UPPER - 0.1  # near the limits: the sum must be clipped back
    base[1] = LOWER + 0.1
    actions = rng.uniform(-1.5, 1.5, size=(6, 28))  # beyond the box: clipped to +-1 first
    actions[0], actions[1] = 1.0, -1.0
    out = np.zeros((6, 28))
    mapper.targets_batch(actions, out, base)
    np.testing.assert_allclose(out, np.clip(base + SCALE * np.clip(actions, -1, 1), LOWER, UPPER), atol=1e-12)
    np.testing.assert_allclose(out[0], UPPER, atol=1e-12)
    np.testing.assert_allclose(out[1], LOWER, atol=1e-12)
    # One action at a time gives the same, and the inverse map recovers the action.
    for k in range(2, 6):
        np.testing.assert_allclose(mapper.targets(actions[k], base=base[k]), out[k], atol=1e-12)
        inside = np.clip(base[k] + SCALE * rng.uniform(-0.9, 0.9, 28), LOWER, UPPER)
        a = mapper.action_for_targets(inside, base=base[k])
        np.testing.assert_allclose(mapper.targets(a, base=base[k]), inside, atol=1e-9)


def test_residual_actions_need_exp_map_a_positive_scale_and_a_base():
    with pytest.raises(ValueError, match="residual"):
        ActionMapper("axis_angle", SCALE)
    for bad in (0.0, -0.5):
        with pytest.raises(ValueError, match="residual"):
            ActionMapper("exp_map", bad)
    with pytest.raises(ValueError, match="base"):
        ActionMapper("exp_map", SCALE).targets_batch(np.zeros((1, 28)), np.zeros((1, 28)))


def test_absolute_exp_map_reaches_the_farther_limit():
    mapper = ActionMapper("exp_map")  # residual_scale None: absolute targets
    assert not mapper.residual and mapper.action_dim == 28
    action = np.zeros(28)
    action[ctrl_index("chest", 0)] = 0.5  # chest limits +-1.2 on every axis
    action[ctrl_index("right_elbow")] = 0.5  # elbow [0, 3.14]
    action[ctrl_index("left_knee")] = 0.5  # knee [-3.14, 0]: positive is past the limit
    targets = mapper.targets(action)
    assert targets[ctrl_index("chest", 0)] == pytest.approx(0.6)
    assert targets[ctrl_index("right_elbow")] == pytest.approx(1.57)
    assert targets[ctrl_index("left_knee")] == pytest.approx(0.0)
    np.testing.assert_allclose(np.delete(targets, [ctrl_index("chest", 0), ctrl_index("right_elbow"), ctrl_index("left_knee")]),
                               np.clip(0.0, LOWER, UPPER)[:25], atol=1e-12)
    np.testing.assert_allclose(mapper.targets(np.ones(28)), np.clip(np.maximum(-LOWER, UPPER), LOWER, UPPER), atol=1e-12)


def test_absolute_axis_angle_is_angle_times_pi_about_the_normalised_axis():
    mapper = ActionMapper("axis_angle")
    assert mapper.action_dim == 36
    action = np.zeros(36)
    action[4 * BALL.index("chest"):4 * BALL.index("chest") + 4] = [0.25, 0.0, 0.0, 2.0]  # pi/4 about z
    action[4 * BALL.index("neck"):4 * BALL.index("neck") + 4] = [0.1, 0.3, 0.4, 0.0]  # 0.1 pi about (.6, .8, 0)
    action[32 + HINGE.index("right_elbow")] = -0.5  # below the elbow's 0
    targets = mapper.targets(action)
    np.testing.assert_allclose(targets[ctrl_index("chest", 0):ctrl_index("chest", 0) + 3], [0.0, 0.0, np.pi / 4], atol=1e-12)
    np.testing.assert_allclose(targets[ctrl_index("neck", 0):ctrl_index("neck", 0) + 3], 0.1 * np.pi * np.array([0.6, 0.8, 0.0]), atol=1e-12)
    assert targets[ctrl_index("right_elbow")] == 0.0


# ------------------------------------------------------------------------ end to end
def test_zero_residual_playback_tracks_the_reference_at_first(walk, humanoid):
    """Zero residual actions are an open-loop PD playback of the reference: close to it for
    the first steps (then the character loses its balance: measured mean reward over the
    first second 0.63-0.79 per phase), and better than the zero absolute action, which
    straightens every joint (0.51-0.63)."""
    means = {}
    for residual in (SCALE, None):
        env = ImitationEnv(walk, EnvConfig(horizon_s=2.0, residual_action_scale=residual), humanoid)
        per_phase = []
        for phase in np.arange(8) / 8:
            env.reset(seed=0, options={"phase": phase})
            rewards = np.zeros(30)  # a fall earns nothing from there on
            for t in range(30):
                _, rewards[t], terminated, _, _ = env.step(np.zeros(28))
                if terminated:
                    break
            if residual is not None:
                assert rewards[:5].min() > 0.85, (phase, rewards[:5])
            per_phase.append(rewards.mean())
        means[residual] = np.array(per_phase)
    assert means[SCALE].mean() > 0.6
    assert (means[SCALE] > means[None]).all() and means[SCALE].mean() > means[None].mean() + 0.05


def test_a_residual_action_offsets_the_joint_from_the_reference(walk, humanoid):
    env = ImitationEnv(walk, EnvConfig(horizon_s=2.0, early_termination=False), humanoid)
    elbow = env.humanoid.joint_qpos_adr[JOINT_NAMES.index("right_elbow")]
    angles = {}
    for push in (0.0, 0.8):  # 0.8 x 0.5 rad = 0.4 rad more bend than the reference's
        env.reset(seed=0, options={"phase": 0.25})
        action = np.zeros(28)
        action[ctrl_index("right_elbow")] = push
        for _ in range(12):
            env.step(action)
        angles[push] = env.data.qpos[elbow]
    assert 0.35 < angles[0.8] - angles[0.0] < 0.42  # PD tracking, under gravity and the swing


def test_vector_env_steps_like_the_single_env(walk, humanoid):
    """Same start, same random actions: the batched path (residual bases gathered per env,
    root sync, zero reward on a fall) gives the single env's rewards and observations."""
    config = EnvConfig(horizon_s=1.0)
    single = ImitationEnv(walk, config, humanoid)
    single.reset(seed=0, options={"init": "fsi"})
    venv = VectorImitationEnv(walk, config, num_envs=1, starts=BufferedStarts(ReferenceStarts("fsi", np.random.default_rng(0)), batch=1), seed=0)
    venv.reset()
    rng = np.random.default_rng(8)
    for step in range(25):
        action = rng.uniform(-1, 1, 28)
        obs, reward, terminated, truncated, _ = single.step(action)
        vobs, vrewards, vterminated, _, vfinal = venv.step(action[None])
        assert vrewards[0] == pytest.approx(reward, rel=1e-9, abs=1e-12), step
        assert bool(vterminated[0]) == terminated
        np.testing.assert_allclose(vfinal[0], obs, rtol=1e-5, atol=1e-5)
        if terminated or truncated:
            break
    assert step > 5


def test_residual_factors_scale_each_joints_range_and_bad_ones_are_refused():
    factors = np.linspace(0.5, 3.0, 28)
    mapper = ActionMapper("exp_map", SCALE, residual_factors=factors)
    base = np.zeros((1, 28))
    out = np.zeros((1, 28))
    mapper.targets_batch(np.full((1, 28), 0.2), out, base)
    expected = np.clip(0.2 * SCALE * factors, LOWER, UPPER)
    np.testing.assert_allclose(out[0], expected, atol=1e-12)
    free = (expected > LOWER) & (expected < UPPER)  # not clipped: the inverse map gives the action back
    assert free[-4:].sum() >= 2
    np.testing.assert_allclose(mapper.action_for_targets(expected * 0.5, np.zeros(28))[-4:][free[-4:]], 0.1, atol=1e-12)
    with pytest.raises(ValueError, match="28 positive numbers"):
        ActionMapper("exp_map", SCALE, residual_factors=np.ones(27))
    with pytest.raises(ValueError, match="28 positive numbers"):
        ActionMapper("exp_map", SCALE, residual_factors=np.zeros(28))
