"""Left/right mirroring (actors/character/mirror.py) and the mirrored expert (services/experts)."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

from actors.character import quaternion as qn
from actors.character.actions import ActionMapper
from actors.character.features import FeatureExtractor, update_kinematics
from actors.character.humanoid3d import Humanoid
from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.character.kinematics import forward_kinematics
from actors.character.skeleton import LINK_MIRROR
from actors.character.mirror import (POLAR, QUAT, action_mirror, mirror_motion, mirrored_name, observation_mirror,
                           state_mirror)
from actors.character.skeleton import JOINT_IS_SPHERICAL, LINKS, OFFSETS
from learner.errors import SfvError


@pytest.fixture(scope="module")
def humanoid():
    return Humanoid()


def _random_state(humanoid, rng):
    """A valid random qpos / qvel (unit quaternions) of the humanoid."""
    data = mujoco.MjData(humanoid.model)
    data.qpos[:] = rng.normal(size=humanoid.nq)
    for adr in [3, *humanoid.joint_qpos_adr[JOINT_IS_SPHERICAL]]:
        data.qpos[adr:adr + 4] /= np.linalg.norm(data.qpos[adr:adr + 4])
    data.qvel[:] = rng.normal(size=humanoid.nv)
    return data


def test_maps_are_involutions(humanoid):
    rng = np.random.default_rng(0)
    qpos_map, qvel_map = state_mirror(humanoid)
    maps = [(qpos_map, humanoid.nq), (qvel_map, humanoid.nv), (action_mirror("exp_map"), 28), (action_mirror("axis_angle"), 36),
            (observation_mirror(humanoid, 2), 197 + 14)]
    for mirror, size in maps:
        x = rng.normal(size=(5, size))
        assert not np.allclose(mirror(x), x)  # it does something
        np.testing.assert_array_equal(mirror(mirror(x)), x)
    assert mirrored_name(mirrored_name("deepmimic:walk")) == "deepmimic:walk"


def test_body_and_limits_are_symmetric():
    """What makes a mirrored policy exact: partner links reflect into each other and the
    action scales and joint limits of partners map onto each other."""
    for i, link in enumerate(LINKS):
        partner = LINKS[LINK_MIRROR[i]]
        np.testing.assert_allclose(OFFSETS[LINK_MIRROR[i]], OFFSETS[i] * POLAR)
        assert (partner.mass, partner.kp, partner.kd, partner.torque_limit) == (link.mass, link.kp, link.kd, link.torque_limit)
    actions, mirror = ActionMapper(residual_scale=None), action_mirror()
    lo, hi = mirror.sign * actions.lower[mirror.source], mirror.sign * actions.upper[mirror.source]
    np.testing.assert_allclose(np.minimum(lo, hi), actions.lower)
    np.testing.assert_allclose(np.maximum(lo, hi), actions.upper)


def test_mirrored_clip_kinematics_mirror_the_link_positions(walk_clip):
    mirrored = mirror_motion(walk_clip)
    assert mirrored.name == walk_clip.name + "_mirror" and mirrored.loop == walk_clip.loop
    pos, rot = forward_kinematics(walk_clip.root_pos, walk_clip.root_rot, walk_clip.joint_rot)
    pos_m, rot_m = forward_kinematics(mirrored.root_pos, mirrored.root_rot, mirrored.joint_rot)
    np.testing.assert_allclose(pos_m, pos[:, LINK_MIRROR] * POLAR, atol=1e-12)
    dots = np.abs(np.sum(rot_m * rot[:, LINK_MIRROR] * QUAT, axis=-1))
    np.testing.assert_allclose(dots, 1.0, atol=1e-9)
    # The walk's left foot leads where the original's right did: the feet are not symmetric by themselves.
    assert np.abs(pos[:, LINK_MIRROR] - pos).max() > 0.1


def test_observation_mirror_equals_the_state_mirrored_into_a_scratch_mjdata(humanoid):
    """The observation of the mirrored state (computed by MuJoCo and FeatureExtractor) is the
    signed permutation of the original's: what MirroredExpert relies on."""
    rng = np.random.default_rng(1)
    qpos_map, qvel_map = state_mirror(humanoid)
    obs_map = observation_mirror(humanoid, 2)
    extractor = FeatureExtractor(humanoid)
    for _ in range(3):
        data = _random_state(humanoid, rng)
        update_kinematics(humanoid.model, data)
        ref = (rng.normal(size=(1, 2, 3)), rng.normal(size=(1, 2, 4)))
        original = extractor.observation(data, 0.3, np.zeros((1, 211)), reference=ref).copy()
        mirrored = mujoco.MjData(humanoid.model)
        mirrored.qpos[:], mirrored.qvel[:] = qpos_map(data.qpos), qvel_map(data.qvel)
        update_kinematics(humanoid.model, mirrored)
        ref_m = (ref[0] * POLAR, ref[1] * QUAT)
        observed = extractor.observation(mirrored, 0.3, np.zeros((1, 211)), reference=ref_m)
        np.testing.assert_allclose(observed, obs_map(original), atol=1e-9)


def test_mirrored_clip_playback_is_a_valid_motion(walk_clip, humanoid):
    """The mirrored clip's reference table is the original's mirrored, and playing it back
    scores reward 1 against itself (`sfv motion check`'s playback)."""
    config = EnvConfig(horizon_s=2.0)
    env, env_m = ImitationEnv(walk_clip, config, humanoid), ImitationEnv(mirror_motion(walk_clip), config, humanoid)
    qpos_map, qvel_map = state_mirror(humanoid)
    np.testing.assert_allclose(env_m.track.qpos, qpos_map(env.track.qpos), atol=1e-12)
    np.testing.assert_allclose(env_m.track.qvel, qvel_map(env.track.qvel), atol=1e-9)
    np.testing.assert_allclose(env_m.track.ctrl, action_mirror()(env.track.ctrl), atol=1e-9)
    for row in range(0, env_m.track.start_steps, 7):
        env_m.set_reference_state(row)
        assert env_m.reward_at(row) == pytest.approx(env_m.max_reward, abs=1e-9)


def test_mirrored_expert_acts_as_the_mirrored_policy(walk_clip, humanoid):
    """A tiny random policy: the mirrored expert's action on the mirrored env is the mirror of
    the policy's action on the original env, step after step of a rollout."""
    from learner.policy import NumpyPolicy
    from services.experts.expert import Expert
    from services.experts.mirrored_expert import MirroredExpert

    rng = np.random.default_rng(2)
    config = EnvConfig(horizon_s=1.0)
    obs_dim = ImitationEnv(walk_clip, config, humanoid).obs_dim
    weights = {"obs_mean": rng.normal(size=obs_dim) * 0.1, "obs_std": np.ones(obs_dim), "obs_clip": np.array(10.0),
               "layer0.weight": rng.normal(size=(obs_dim, 16)) * 0.1, "layer0.bias": np.zeros(16),
               "layer1.weight": rng.normal(size=(16, 28)), "layer1.bias": rng.normal(size=28) * 0.1, "action_std": np.full(28, 0.1)}
    expert = Expert(NumpyPolicy(weights), config, "deepmimic:walk", "walk")
    mirrored = MirroredExpert(expert)
    assert mirrored.motion == "deepmimic:walk_mirror" and mirrored.name == "walk_mirror"
    env, env_m = ImitationEnv(walk_clip, config, humanoid), ImitationEnv(mirror_motion(walk_clip), config, humanoid)
    obs, _ = env.reset(options={"init": "rsi", "phase": 0.25})
    obs_m, _ = env_m.reset(options={"init": "rsi", "phase": 0.25})
    amap = action_mirror()
    for _ in range(10):
        action, action_m = expert.act(obs[None]), mirrored.act(obs_m[None])
        np.testing.assert_allclose(action_m, amap(action), atol=1e-5)
        assert np.abs(action).max() > 0.05  # the policy does act
        obs, *_ = env.step(action[0])
        obs_m, *_ = env_m.step(action_m[0])
    np.testing.assert_allclose(env_m.data.qpos, state_mirror(humanoid)[0](env.data.qpos), atol=1e-6)


def test_a_motion_file_name_with_the_mirror_suffix_loads_the_file_mirrored(walk_clip, tmp_path):
    from actors.motion.bend import bend_motion
    from actors.motion.formats.io import load_motion, save_motion

    path = save_motion(bend_motion(walk_clip, 0.5, 2.0, name="walk_left"), tmp_path / "walk_left.npz")
    mirrored = load_motion(f"{path}_mirror")
    original = load_motion(str(path))
    np.testing.assert_allclose(mirrored.root_pos[:, 1], -original.root_pos[:, 1])
    assert np.degrees(np.unwrap(qn.heading_angle(mirrored.root_rot))[-1]) < -50  # turns right
    with pytest.raises(SfvError, match="not found"):
        load_motion(str(tmp_path / "absent.npz_mirror"))


def test_observation_mirror_covers_the_reference_pose_block(walk_clip, humanoid):
    """With the reference's poses observed (`reference_pose_obs_steps`), the mirrored clip's
    observation at the mirrored reference state is the mapped original's, pose block included."""
    config = EnvConfig(horizon_s=2.0, reference_pose_obs_steps=(1, 15))
    env, env_m = ImitationEnv(walk_clip, config, humanoid), ImitationEnv(mirror_motion(walk_clip), config, humanoid)
    obs_map = observation_mirror(humanoid, len(config.reference_obs_steps), len(config.reference_pose_obs_steps))
    assert obs_map(np.zeros((1, env.obs_dim))).shape == (1, env.obs_dim)
    for phase in (0.1, 0.6):
        original, _ = env.reset(options={"init": "rsi", "phase": phase})
        mirrored, _ = env_m.reset(options={"init": "rsi", "phase": phase})
        pose = slice(env.obs_dim - env.reference_pose_obs.width, env.obs_dim)
        assert np.abs(original[pose]).max() > 0.1  # the block is filled
        np.testing.assert_allclose(mirrored, obs_map(original[None])[0], atol=1e-5)
