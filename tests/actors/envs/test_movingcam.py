"""The env's movingcam mode (002 §5): reward terms, contacts XOR, termination rules, the
preset, bad motions, root-free observation, and single env = vector env."""
import numpy as np
import pytest

from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.motion.reference_motion import MotionFormatError
from actors.envs.modes.movingcam.termination import RULES, MovingcamTermination, MovingcamTerminationConfig
from actors.envs.modes.movingcam.reward import MovingcamReward, MovingcamRewardConfig

MOVINGCAM = EnvConfig(mode="movingcam", horizon_s=2.0)


@pytest.fixture(scope="module")
def walk():
    pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")
    from actors.motion.formats.io import load_motion

    return load_motion("deepmimic:walk")


@pytest.fixture(scope="module")
def env(walk):
    return ImitationEnv(walk, MOVINGCAM)


def _score(env, sim_values, tilt, sim_contacts, torque, rows, config=None):
    """Rewards and terms of hand-made simulated features against the env's reference rows."""
    from actors.character.features import RewardFeatures

    b = len(rows)
    targets = env.movingcam.targets
    reward = MovingcamReward(config or MovingcamRewardConfig(), b, len(targets.contact_links), env.model.nu, env.model.nv - 6)
    terms = np.zeros((b, 5))
    ref = env.track.features.take(rows)
    r = reward.batch(RewardFeatures(sim_values), ref, tilt, targets.hint[rows], targets.hint_weight[rows], sim_contacts,
                     targets.contacts[rows], torque, terms)
    return r.copy(), terms, reward


def _perfect(env, rows):
    targets = env.movingcam.targets
    return (env.track.features.values[rows].copy(), targets.hint[rows].copy(), targets.contacts[rows] > 0.5,
            np.zeros((len(rows), env.model.nu)))


def test_perfect_tracking_scores_one_and_each_error_lowers_its_term(env):
    rows = np.arange(0, 40, 4)
    sim, tilt, contacts, torque = _perfect(env, rows)
    r, terms, _ = _score(env, sim, tilt, contacts, torque, rows)
    np.testing.assert_allclose(terms, 1.0, atol=1e-12)
    np.testing.assert_allclose(r, 1.0, atol=1e-12)
    previous = np.ones(len(rows))
    for offset in (0.05, 0.1, 0.2):  # knee angles (hinge columns) off by more and more
        worse = sim.copy()
        worse[:, 36:40] += offset
        _, t, reward = _score(env, worse, tilt, contacts, torque, rows)
        np.testing.assert_allclose(reward.pose_error, 4 * offset**2, rtol=1e-9)
        np.testing.assert_allclose(t[:, 0], np.exp(-12 * 4 * offset**2 / 12), rtol=1e-9)  # mean over the 12 joints
        assert (t[:, 0] < previous).all() and (t[:, 1:] == terms[:, 1:]).all()
        previous = t[:, 0]
    _, t, _ = _score(env, worse, tilt, contacts, torque, rows, MovingcamRewardConfig(joint_error="sum"))
    np.testing.assert_allclose(t[:, 0], np.exp(-12 * 4 * 0.2**2), rtol=1e-9)  # eq. 6 as printed
    fast = sim.copy()
    fast[:, 40 + 3:40 + 6] += 2.0  # the first ball joint's angular velocity (qvel[6:9])
    _, t, _ = _score(env, fast, tilt, contacts, torque, rows)
    np.testing.assert_allclose(t[:, 1], np.exp(-0.6 * 12.0 / (env.model.nv - 6)), rtol=1e-9)
    root_spin = sim.copy()
    root_spin[:, 40:43] += 5.0  # the root's angular velocity is not a joint's
    root_spin[:, :4] = [0.0, 0.0, 0.0, 1.0]  # nor is its rotation
    _, t, _ = _score(env, root_spin, tilt, contacts, torque, rows)
    np.testing.assert_allclose(t[:, :2], 1.0, atol=1e-12)
    _, t, _ = _score(env, sim, tilt + 0.3, contacts, torque, rows)
    np.testing.assert_allclose(t[:, 2], np.exp(-5 * 0.09), rtol=1e-9)
    _, t, _ = _score(env, sim, tilt, contacts, np.full_like(torque, 0.1), rows)
    np.testing.assert_allclose(t[:, 4], np.exp(-env.model.nu * 0.01), rtol=1e-9)


def test_contact_term_counts_the_xor_of_simulated_and_estimated_flags(env):
    rows = np.array([0, 5, 25])
    sim, tilt, contacts, torque = _perfect(env, rows)
    assert (contacts[0] == [True, True]).all() and (contacts[2] == [False, True]).all()  # walk: double, single support
    one_off = contacts.copy()
    one_off[:, 0] = ~one_off[:, 0]
    _, t, _ = _score(env, sim, tilt, one_off, torque, rows)
    np.testing.assert_allclose(t[:, 3], np.exp(-2.0), rtol=1e-12)
    _, t, _ = _score(env, sim, tilt, ~contacts, torque, rows)
    np.testing.assert_allclose(t[:, 3], np.exp(-4.0), rtol=1e-12)


def test_hand_flags_join_the_contact_term(walk):
    from actors.envs.modes.movingcam.clip_cues import clip_cues
    from actors.motion.reference_motion import ReferenceMotion

    cues = clip_cues(walk)
    hands = np.zeros((walk.num_frames, 2), dtype=bool)
    cues.update(contacts=np.concatenate((cues["contacts"], hands), axis=1),
                contact_feet=np.array(("right", "left", "right_hand", "left_hand")))
    motion = ReferenceMotion(walk.name, walk.frame_times, walk.root_pos, walk.root_rot, walk.joint_rot, walk.loop, cues)
    env = ImitationEnv(motion, MOVINGCAM)
    targets = env.movingcam.targets
    assert targets.has_hands and targets.contacts.shape[1] == 4
    from actors.character.skeleton import LINK_NAMES

    assert [LINK_NAMES[i] for i in targets.contact_links] == ["right_ankle", "left_ankle", "right_wrist", "left_wrist"]


def test_each_termination_rule_fires_alone():
    rule = MovingcamTermination(MovingcamTerminationConfig(com_drop_m=0.3, joint_angle_error_rad=0.5, orientation_error_rad=0.6), 5)
    com = np.array([0.9, 0.5, 0.9, 0.9, 0.9])
    pose = np.array([0.0, 0.0, 12 * 0.51**2, 0.0, 0.0])
    gap = np.array([0.0, 0.0, 0.0, 0.61, 0.0])
    hit = np.array([False, False, False, False, True])
    ended = rule.check(com, np.full(5, 0.9), pose, gap, hit)
    np.testing.assert_array_equal(ended, [False, True, True, True, True])
    np.testing.assert_array_equal(rule.fired[1:], np.eye(len(RULES), dtype=bool))
    ended = rule.check(np.full(5, 0.9), np.full(5, 0.9), np.full(5, 12 * 0.49**2), np.full(5, 0.59), np.zeros(5, bool))
    assert not ended.any()
    off = MovingcamTermination(MovingcamTerminationConfig(None, None, None, False), 5)
    assert not off.check(com, np.full(5, 0.9), pose, gap, hit).any()


def test_env_ends_on_the_orientation_hint_and_on_an_obstacle(walk):
    from actors.motion.reference_motion import ReferenceMotion

    extras = {"orientation_hint": np.full(walk.num_frames, 1.5), "contacts": np.ones((walk.num_frames, 2), dtype=bool)}
    leaning = ReferenceMotion(walk.name, walk.frame_times, walk.root_pos, walk.root_rot, walk.joint_rot, walk.loop, extras)
    env = ImitationEnv(leaning, MOVINGCAM)
    env.reset(seed=0, options={"init": "fsi"})
    _, reward, terminated, _, _ = env.step(np.zeros(env.action_space.shape))
    assert terminated and reward == 0.0 and env.movingcam.termination.fired[0].tolist() == [False, False, True, False]
    # The floor as an "obstacle": the character dropped on its back touches it with its torso.
    env = ImitationEnv(walk, MOVINGCAM)
    env.movingcam.set_obstacles((env.humanoid.floor_geom_id,))
    env.reset(seed=0, options={"init": "fsi"})
    env.data.qpos[2] = 0.12
    env.data.qpos[3:7] = [np.cos(np.pi / 4), 0.0, np.sin(np.pi / 4), 0.0]  # lying
    _, _, terminated, _, _ = env.step(np.zeros(env.action_space.shape))
    assert terminated and env.movingcam.termination.fired[0, 3]


def test_root_path_does_not_reach_the_policy_or_the_reward(walk):
    """The clip and its root-free copy (same cues) give the same observations and rewards
    (once started with the same root velocity: the root-free copy's reference has none)."""
    from actors.envs.modes.movingcam.clip_cues import clip_cues
    from services.reconstruction.root_free import make_root_free

    free = make_root_free(walk)
    free.extras.update(clip_cues(walk))
    a, b = ImitationEnv(walk, MOVINGCAM), ImitationEnv(free, MOVINGCAM)
    rng = np.random.default_rng(0)
    a.reset(seed=0, options={"init": "fsi"})
    b.reset(seed=0, options={"init": "fsi"})
    assert np.abs(b.data.qvel[:2]).max() == 0.0 < np.abs(a.data.qvel[:2]).max()
    b.data.qvel[:] = a.data.qvel
    for _ in range(15):
        action = rng.uniform(-1, 1, a.action_space.shape)
        obs_a, r_a, *_ = a.step(action)
        obs_b, r_b, *_ = b.step(action)
        np.testing.assert_allclose(obs_a, obs_b, atol=1e-6)
        assert r_a == pytest.approx(r_b, abs=1e-9)
    assert np.abs(walk.root_pos[-1, :2]).max() > 0.5  # the clip does travel


def test_root_free_motion_without_cues_is_a_one_line_error_naming_the_file(walk, tmp_path, capsys):
    from actors.motion.formats.io import load_motion, save_motion
    from services.cli import main
    from services.reconstruction.root_free import make_root_free

    path = save_motion(make_root_free(walk), tmp_path / "panned.npz")
    with pytest.raises(MotionFormatError, match=r"panned\.npz: movingcam mode needs the video's orientation_hint and contacts"):
        ImitationEnv(load_motion(str(path)), MOVINGCAM)
    code = main(["train", "--motion", str(path), "--preset", "movingcam", "--serial", "--samples", "1024",
                 "--out", str(tmp_path / "run")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "panned.npz" in err and "contacts" in err


def test_reward_preset_selects_the_mode_with_residual_targets():
    from services.training.flags import resolve

    config = resolve({}, {}, None, "movingcam")
    assert config.env.mode == "movingcam" and config.env.residual_action_scale == 0.5
    assert config.env.max_reward == pytest.approx(1.0)
    mine = resolve({"env.residual_action_scale": 0.25, "env.movingcam.reward.contact_weight": 0.5}, {}, None, "movingcam")
    assert mine.env.residual_action_scale == 0.25 and mine.env.movingcam.reward.contact_weight == 0.5
    assert resolve({}, {}, None, "deepmimic").env.mode == "sfv"
    from services.training.config import TrainConfig

    again = TrainConfig.from_dict(mine.to_dict())  # a saved run config reads back
    assert again.env.movingcam == mine.env.movingcam


def test_vector_env_and_single_env_give_identical_rewards(walk):
    from actors.envs.initial_states import BufferedStarts, ReferenceStarts
    from actors.envs.vector_env import VectorImitationEnv

    venv = VectorImitationEnv(walk, MOVINGCAM, num_envs=3, starts=BufferedStarts(ReferenceStarts("rsi", np.random.default_rng(3)), batch=3), seed=5)
    venv.reset()
    singles = []
    for inner in venv.envs:
        single = ImitationEnv(walk, MOVINGCAM)
        obs, _ = single.reset(seed=0, options={"init": "rsi", "phase": inner.phase})
        assert single.row == inner.row
        np.testing.assert_array_equal(obs, venv.obs[len(singles)])
        singles.append(single)
    rng = np.random.default_rng(1)
    alive = np.ones(3, dtype=bool)
    for _ in range(20):
        actions = rng.uniform(-1, 1, (3, venv.action_dim))
        _, rewards, terminated, truncated, final_obs = venv.step(actions)
        for i, single in enumerate(singles):
            if not alive[i]:
                continue
            obs, reward, term, trunc, _ = single.step(actions[i])
            assert reward == pytest.approx(float(rewards[i]), abs=1e-6) and (term, trunc) == (terminated[i], truncated[i])
            np.testing.assert_allclose(obs, final_obs[i], atol=1e-5)
            alive[i] = not (term or trunc)
    assert venv.max_reward == singles[0].max_reward == pytest.approx(1.0)
