"""Left/right mirroring of the Unitree G1 (actors/character/mirror.py), proven by MuJoCo's own
forward kinematics: the hinge mirror signs derived from the compiled model, poses and robot
motions mirrored, the observation and action maps a mirrored G1 expert acts through.

The G1's MJCF is not exactly symmetric. In its kinematic tree the one difference is the right
shoulder's offset from the torso, y = -0.10021 against the left's 0.10022 (1e-5 m; the hinge
axes, the links' rest frames, masses, joint ranges and armatures reflect exactly). Every body
below a shoulder is that offset away from its partner's reflection, turned by the arm's
rotations, so the forward-kinematics test bounds each body by the offsets' asymmetries on its
chain (1e-5 m for the arms, 1e-9 m elsewhere), and proves the maps exact (1e-9 m everywhere) on a
copy of the model with the asymmetries taken out (`symmetric_g1`). The others touch only the
dynamics: the torso's centre of mass 0.34 mm off the plane (the waist yaw link's 0.23 mm), the
knees' inertia tensors 9e-5 kg m^2 apart (0.8 %), one sole capsule (left_foot1) 1 mm off at one
end. Needs the cached model (`sfv models fetch --robot g1`)."""
from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from actors.character import g1_model
from actors.character import g1_spec as spec
from actors.character.mirror import POLAR, QUAT, action_mirror, mirror_motion, observation_mirror, state_mirror
from actors.character.symmetry import check_mirror_signs, derive_hinge_mirror_signs, mirror_asymmetry
from learner.errors import SfvError

pytestmark = pytest.mark.skipif(not g1_model.model_available(), reason="G1 model not cached (sfv models fetch --robot g1)")
EXACT_M = 1e-9  # what floating point leaves of an exact reflection (m)
S = np.diag(POLAR)


@pytest.fixture(scope="module")
def g1():
    from actors.character.g1 import G1Model

    return G1Model()


@pytest.fixture(scope="module")
def symmetric_g1():
    """The G1 with its MJCF's asymmetries taken out: each right link's offset, centre of mass and
    inertia the left partner's reflection, the centre-line links' centres of mass put in the
    plane and their inertias symmetrised, the one off sole capsule (left_foot1) its partner's
    reflection."""
    from actors.character.g1 import G1Model

    body = G1Model()
    m, ids, partner = body.model, body.body_ids, spec.LINK_MIRROR
    for link in range(len(spec.LINK_NAMES)):
        b, p = ids[link], ids[partner[link]]
        if spec.LINK_NAMES[link].startswith("right_"):
            m.body_pos[b], m.body_ipos[b] = m.body_pos[p] * POLAR, m.body_ipos[p] * POLAR
            m.body_iquat[b], m.body_inertia[b] = m.body_iquat[p] * QUAT, m.body_inertia[p]
        elif b == p:
            frame = np.zeros(9)
            mujoco.mju_quat2Mat(frame, m.body_iquat[b])
            inertia = frame.reshape(3, 3) @ np.diag(m.body_inertia[b]) @ frame.reshape(3, 3).T
            values, axes = np.linalg.eigh(0.5 * (inertia + S @ inertia @ S))
            axes[:, 0] *= np.sign(np.linalg.det(axes))
            mujoco.mju_mat2Quat(m.body_iquat[b], axes.ravel())
            m.body_inertia[b], m.body_ipos[b][1] = values, 0.0
    left, right = (mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, n) for n in ("left_foot1_collision", "right_foot7_collision"))
    m.geom_pos[left], m.geom_quat[left], m.geom_size[left] = m.geom_pos[right] * POLAR, m.geom_quat[right] * QUAT, m.geom_size[right]
    return body


def _chain_bound(body) -> np.ndarray:
    """Per link: the sum over its chain (itself and its ancestors) of |p' - S p|, p a body's
    offset from its parent and p' its partner's: how far the link of a mirrored pose can be from
    its partner's reflection when the offsets are all that differ (rotations are orthogonal)."""
    model, ids, partner = body.model, body.body_ids, spec.LINK_MIRROR
    own = np.zeros(model.nbody)
    own[ids] = np.linalg.norm(model.body_pos[ids[partner]] - model.body_pos[ids] * POLAR, axis=1)
    bound = own.copy()
    for b in range(1, model.nbody):  # parents come before children
        bound[b] = own[b] + (bound[model.body_parentid[b]] if model.body_parentid[b] > 0 else 0.0)
    return bound[ids]


def _random_qpos(rng, count: int) -> np.ndarray:
    """(count, 36) G1 poses: a root anywhere, any orientation, the 29 angles within their limits."""
    root_pos = rng.uniform(-2.0, 2.0, size=(count, 3))
    quat = rng.normal(size=(count, 4))
    quat /= np.linalg.norm(quat, axis=1, keepdims=True)
    angles = rng.uniform(spec.JOINT_LIMITS[:, 0], spec.JOINT_LIMITS[:, 1], size=(count, spec.NUM_JOINTS))
    return np.concatenate((root_pos, quat, angles), axis=1)


def _kinematics(body, qpos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    data = mujoco.MjData(body.model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(body.model, data)
    return data.xpos[body.body_ids].copy(), data.xmat[body.body_ids].reshape(-1, 3, 3).copy()


def _synthetic_motion(frames: int = 40, fps: float = 30.0):
    """A smooth G1 motion (no retargeting): the standing pose swaying, every hinge moving within
    its limits, the root walking forward and turning."""
    from actors.motion.robot_motion import RobotMotion

    t = np.arange(frames) / fps
    lo, hi = spec.JOINT_LIMITS[:, 0], spec.JOINT_LIMITS[:, 1]
    phase = np.arange(spec.NUM_JOINTS) * 0.7
    angles = spec.standing_joint_angles() + 0.25 * np.sin(2.0 * np.pi * 1.1 * t[:, None] + phase)
    angles = np.clip(angles, lo + 1e-3, hi - 1e-3)
    yaw = 0.3 * t
    root_quat = np.stack((np.cos(yaw / 2), 0.02 * np.sin(3 * t), 0.03 * np.cos(2 * t), np.sin(yaw / 2)), axis=1)
    root_quat /= np.linalg.norm(root_quat, axis=1, keepdims=True)
    root_pos = np.stack((0.5 * t, 0.1 * np.sin(t), 0.76 + 0.01 * np.sin(6 * t)), axis=1)
    contacts = np.stack((np.sin(4 * t) > 0, np.sin(4 * t) <= 0), axis=1)
    return RobotMotion("g1", "sway", "synthetic", fps, False, spec.JOINT_NAMES, root_pos, root_quat, angles, contacts)


def test_the_hinge_mirror_signs_are_read_off_the_model(g1):
    """The G1 faces +x with its left at +y, so it mirrors in the world's x-z plane; reflecting
    world axes there, the pitch hinges, knees and elbows keep their angle and every roll and yaw
    hinge flips it, tilted hips and shoulders included; the table in g1_spec says the same."""
    ids = g1.body_ids
    xpos, _ = _kinematics(g1, np.concatenate(([0, 0, 0.793, 1, 0, 0, 0], np.zeros(29))))
    left, right = spec.LINK_NAMES.index("left_hip_pitch_link"), spec.LINK_NAMES.index("right_hip_pitch_link")
    assert xpos[left][1] > 0.06 and xpos[right][1] < -0.06 and abs(xpos[left][0] - xpos[right][0]) < 1e-12
    signs = derive_hinge_mirror_signs(g1)
    np.testing.assert_array_equal(signs, spec.JOINT_MIRROR_SIGN)
    np.testing.assert_array_equal(check_mirror_signs(g1), spec.JOINT_MIRROR_SIGN)
    flipped = {n for n, s in zip(spec.JOINT_NAMES, signs) if s < 0}
    # 7 a side (hip roll / yaw, ankle roll, shoulder roll / yaw, wrist roll / yaw) and the waist's yaw and roll
    assert flipped == {n for n in spec.JOINT_NAMES if "roll" in n or "yaw" in n} and len(flipped) == 16
    assert ids.tolist() == list(range(1, 31))


def test_the_humanoid_signs_are_its_hinges_unchanged(shared_humanoid):
    np.testing.assert_array_equal(derive_hinge_mirror_signs(shared_humanoid), np.ones(12))
    assert mirror_asymmetry(shared_humanoid)["link_position_m"] == 0.0


def test_the_g1_asymmetry_is_the_right_shoulder_offset(g1, symmetric_g1):
    found = mirror_asymmetry(g1)
    assert found["link_position_m"] == pytest.approx(1e-5, rel=1e-6)
    assert found["link_position_link"] == "left_shoulder_pitch_link"
    assert found["link_frame"] == 0.0 and found["hinge_axis"] == 0.0
    bound = _chain_bound(g1)
    arms = [i for i, n in enumerate(spec.LINK_NAMES) if any(k in n for k in ("shoulder", "elbow", "wrist"))]
    assert bound[arms] == pytest.approx(1e-5, rel=1e-6) and np.delete(bound, arms).max() == 0.0
    assert mirror_asymmetry(symmetric_g1)["link_position_m"] < 1e-15


def test_a_wrong_sign_or_an_unsymmetric_axis_is_an_error(g1, monkeypatch):
    from actors.character.g1 import G1, G1Model

    wrong = spec.JOINT_MIRROR_SIGN.copy()
    wrong[spec.JOINT_NAMES.index("left_knee_joint")] = -1.0
    monkeypatch.setattr(G1, "joint_mirror_sign", wrong)
    with pytest.raises(SfvError, match="joint_mirror_sign disagrees with its model's hinge axes at left_knee_joint$"):
        state_mirror(g1)
    monkeypatch.undo()
    tilted = G1Model()
    joint = mujoco.mj_name2id(tilted.model, mujoco.mjtObj.mjOBJ_JOINT, "left_hip_roll_joint")
    tilted.model.jnt_axis[joint] = (0.0, 0.6, 0.8)
    with pytest.raises(SfvError, match="left_hip_roll_joint .* does not reflect onto right_hip_roll_joint's axis") as exc:
        derive_hinge_mirror_signs(tilted)
    assert "\n" not in str(exc.value)


@pytest.mark.parametrize("which", ["g1", "symmetric_g1"])
def test_mirrored_poses_put_every_body_at_its_partners_reflection(which, request):
    """Random poses (root anywhere, 29 angles within limits): every link of the mirrored pose is
    at the reflection of its partner's position in the original (within the offsets' asymmetry
    on its chain, 1e-9 m on the symmetrised model) and turned by S R S of its partner's rotation;
    mirroring twice is the original, bit for bit."""
    body = request.getfixturevalue(which)
    qpos_map, _ = state_mirror(body)
    bound = _chain_bound(body) + EXACT_M
    rng = np.random.default_rng(0)
    worst = 0.0
    for qpos in _random_qpos(rng, 50):
        mirrored = qpos_map(qpos)
        np.testing.assert_array_equal(qpos_map(mirrored), qpos)
        assert np.all(spec.JOINT_LIMITS[:, 0] <= mirrored[7:]) and np.all(mirrored[7:] <= spec.JOINT_LIMITS[:, 1])
        xpos, xmat = _kinematics(body, qpos)
        xpos_m, xmat_m = _kinematics(body, mirrored)
        error = np.linalg.norm(xpos_m[spec.LINK_MIRROR] - xpos * POLAR, axis=1)
        assert np.all(error <= bound), spec.LINK_NAMES[int(np.argmax(error - bound))]
        np.testing.assert_allclose(xmat_m[spec.LINK_MIRROR], S @ xmat @ S, atol=1e-12)
        worst = max(worst, error.max())
    if which == "g1":
        assert 5e-6 < worst <= 1e-5 + EXACT_M  # the shoulder's offset shows, and is all that does
    else:
        assert worst <= EXACT_M


def test_a_robot_motion_mirrors_as_its_poses(g1, tmp_path):
    from actors.character.characters import character_named
    from actors.motion.character_reference import load_reference
    from actors.motion.robot_motion import mirror_robot_motion, save_robot_motion
    from actors.motion.robot_reference import robot_reference

    robot = character_named("g1")
    motion = _synthetic_motion()
    mirrored = mirror_robot_motion(motion)
    assert (mirrored.name, mirrored.source) == ("sway_mirror", "synthetic_mirror")
    qpos_map, _ = state_mirror(g1)
    np.testing.assert_array_equal(mirrored.qpos(), qpos_map(motion.qpos()))
    np.testing.assert_array_equal(mirrored.contacts, motion.contacts[:, ::-1])
    twice = mirror_robot_motion(mirrored)
    assert twice.name == motion.name and twice.source == motion.source
    # A retargeted clip's name keeps its body last, as the retargeting of the mirrored clip names it.
    cartwheel = mirror_robot_motion(dataclasses.replace(motion, name="deepmimic:cartwheel_g1", source="deepmimic:cartwheel"))
    assert (cartwheel.name, cartwheel.source) == ("deepmimic:cartwheel_mirror_g1", "deepmimic:cartwheel_mirror")
    assert mirror_robot_motion(cartwheel).name == "deepmimic:cartwheel_g1"
    for key in ("root_pos", "root_quat", "joint_pos", "contacts"):
        np.testing.assert_array_equal(getattr(twice, key), getattr(motion, key))
    # The reference of the mirrored file is the mirrored reference (hinges as rotations about their axes).
    reference, reference_m = robot_reference(motion, robot), robot_reference(mirrored, robot)
    by_quats = mirror_motion(reference)
    assert by_quats.character == "g1" and by_quats.name == "sway_mirror"
    np.testing.assert_allclose(by_quats.joint_rot, reference_m.joint_rot, atol=1e-15)
    np.testing.assert_allclose(by_quats.root_rot, reference_m.root_rot, atol=1e-15)
    # FILE_mirror of a robot motion file loads that file mirrored.
    path = save_robot_motion(motion, tmp_path / "sway_g1.npz")
    loaded = load_reference(f"{path}_mirror", robot)
    assert loaded.character == "g1" and loaded.name == "sway_mirror"
    np.testing.assert_allclose(loaded.joint_rot, reference_m.joint_rot, atol=1e-12)


def test_observation_mirror_equals_the_mirrored_state_observed(g1, symmetric_g1):
    """The observation of the mirrored state (MuJoCo and FeatureExtractor) is the signed
    permutation of the original's, what a mirrored G1 expert reads: exactly (1e-9) on the
    symmetrised model; on the G1 the arms' positions are off by the shoulder's 1e-5 m, and their
    linear velocities by (angular velocity) x that offset."""
    from actors.character.features import FeatureExtractor, update_kinematics, obs_dim

    rng = np.random.default_rng(1)
    for body, tolerance in ((symmetric_g1, 1e-9), (g1, None)):  # (the inertias are not observed)
        qpos_map, qvel_map = state_mirror(body)
        obs_map = observation_mirror(body, 2)
        width = obs_dim(body.character) + 14  # two reference roots
        extractor = FeatureExtractor(body)
        for qpos in _random_qpos(rng, 5):
            data = mujoco.MjData(body.model)
            data.qpos[:], data.qvel[:] = qpos, rng.normal(size=body.nv)
            update_kinematics(body.model, data)
            ref = (rng.normal(size=(1, 2, 3)), rng.normal(size=(1, 2, 4)))
            original = extractor.observation(data, 0.3, np.zeros((1, width)), reference=ref).copy()
            mirrored = mujoco.MjData(body.model)
            mirrored.qpos[:], mirrored.qvel[:] = qpos_map(data.qpos), qvel_map(data.qvel)
            update_kinematics(body.model, mirrored)
            observed = extractor.observation(mirrored, 0.3, np.zeros((1, width)), reference=(ref[0] * POLAR, ref[1] * QUAT))
            if tolerance is None:  # the asymmetry's size: offset 1e-5 m times (1 + the links' angular speeds)
                speed = np.linalg.norm(data.cvel[body.body_ids, :3], axis=1).max()
                tolerance = 1e-5 * (1.0 + 2.0 * speed)
                assert np.abs(observed - obs_map(original)).max() > 1e-7  # the asymmetry shows
            np.testing.assert_allclose(observed, obs_map(original), atol=tolerance)


def test_action_mirror_maps_the_targets_and_the_limits(g1):
    """The action map is the PD targets' map (hinges: the partner's times the sign), and the
    partners' limits reflect into each other, so scaling and clipping commute with it."""
    from actors.character.actions import ActionMapper
    from actors.character.characters import character_named

    robot = character_named("g1")
    mirror = action_mirror("exp_map", robot)
    np.testing.assert_array_equal(mirror.source, spec.JOINT_MIRROR)
    np.testing.assert_array_equal(mirror.sign, spec.JOINT_MIRROR_SIGN)
    for residual in (None, 0.3):
        actions = ActionMapper(residual_scale=residual, character=robot)
        lo, hi = mirror.sign * actions.lower[mirror.source], mirror.sign * actions.upper[mirror.source]
        np.testing.assert_array_equal(np.minimum(lo, hi), actions.lower)
        np.testing.assert_array_equal(np.maximum(lo, hi), actions.upper)
        rng = np.random.default_rng(2)
        action = rng.uniform(-1.5, 1.5, size=(4, 29))
        base = rng.uniform(spec.JOINT_LIMITS[:, 0], spec.JOINT_LIMITS[:, 1], size=(4, 29))
        out, out_m = np.zeros((4, 29)), np.zeros((4, 29))
        actions.targets_batch(action, out, base if residual else None)
        actions.targets_batch(mirror(action), out_m, mirror(base) if residual else None)
        np.testing.assert_allclose(out_m, mirror(out), atol=1e-15)
    with pytest.raises(ValueError, match="permutation"):
        type(mirror)(np.zeros(3), np.ones(3))


def _sway_envs(body):
    from actors.envs.imitation_env import EnvConfig, ImitationEnv
    from actors.motion.robot_motion import mirror_robot_motion
    from actors.motion.robot_reference import robot_reference

    motion = _synthetic_motion()
    # 0.5 rad residuals on every joint: the maps are under test, not the range. At the G1's per-joint
    # range (up to 2.2 rad per unit) this random policy's targets swing the joints so hard that the
    # rollouts turn chaotic and float32 rounding of the actions grows from 1e-6 to 1e-3 in 10 steps.
    config = EnvConfig(character="g1", horizon_s=1.0, reference_pose_obs_steps=(1, 15), residual_scale_per_joint=False)
    reference, reference_m = robot_reference(motion, body.character), robot_reference(mirror_robot_motion(motion), body.character)
    return config, ImitationEnv(reference, config, body), ImitationEnv(reference_m, config, body)


def test_the_mirrored_reference_track_and_observations_of_the_env(g1):
    """An env on the mirrored robot motion: its reference table (qpos, qvel, PD targets) is the
    original's mirrored, the mirrored reference played back scores 1 against itself, and after a
    reference-state reset at the same phase its observation (reference roots and poses
    included) is the mapped original's, within the shoulder's asymmetry."""
    config, env, env_m = _sway_envs(g1)
    qpos_map, qvel_map = state_mirror(g1)
    np.testing.assert_allclose(env_m.track.qpos, qpos_map(env.track.qpos), atol=1e-12)
    np.testing.assert_allclose(env_m.track.qvel, qvel_map(env.track.qvel), atol=1e-9)
    np.testing.assert_allclose(env_m.track.ctrl, action_mirror("exp_map", g1.character)(env.track.ctrl), atol=1e-12)
    obs_map = observation_mirror(g1, len(config.reference_obs_steps), len(config.reference_pose_obs_steps))
    for phase in (0.1, 0.6):
        original, _ = env.reset(options={"init": "rsi", "phase": phase})
        mirrored, _ = env_m.reset(options={"init": "rsi", "phase": phase})
        pose = slice(env.obs_dim - env.reference_pose_obs.width, env.obs_dim)
        assert np.abs(original[pose]).max() > 0.1
        np.testing.assert_allclose(mirrored, obs_map(original[None])[0], atol=1e-4)
    for row in range(0, env_m.track.start_steps, 7):
        env_m.set_reference_state(row)
        assert env_m.reward_at(row) == pytest.approx(env_m.max_reward, abs=1e-9)


def _rollouts(body, steps: int = 10) -> tuple[list[float], float]:
    """A tiny random policy on `body` and its mirrored expert on the mirrored motion, stepped side
    by side from the same phase: each step's |mirrored action - mirror(action)| and the final
    |qpos_mirrored - mirror(qpos)|."""
    from learner.policy import NumpyPolicy
    from services.experts.expert import Expert
    from services.experts.mirrored_expert import MirroredExpert

    config, env, env_m = _sway_envs(body)
    rng = np.random.default_rng(3)
    obs_dim, act = env.obs_dim, 29
    weights = {"obs_mean": rng.normal(size=obs_dim) * 0.1, "obs_std": np.ones(obs_dim), "obs_clip": np.array(10.0),
               "layer0.weight": rng.normal(size=(obs_dim, 16)) * 0.1, "layer0.bias": np.zeros(16),
               "layer1.weight": rng.normal(size=(16, act)) * 0.1, "layer1.bias": rng.normal(size=act) * 0.1,
               "action_std": np.full(act, 0.1)}
    expert = Expert(NumpyPolicy(weights), config, "sway.npz", "sway")
    mirrored = MirroredExpert(expert)  # compiles the G1 itself: the maps only need its layout
    assert mirrored.motion == "sway.npz_mirror" and mirrored.name == "sway_mirror"
    amap = action_mirror("exp_map", body.character)
    obs, _ = env.reset(options={"init": "rsi", "phase": 0.25})
    obs_m, _ = env_m.reset(options={"init": "rsi", "phase": 0.25})
    gaps = []
    for _ in range(steps):
        action, action_m = expert.act(obs[None]), mirrored.act(obs_m[None])
        assert np.abs(action).max() > 0.5  # the policy does act
        gaps.append(float(np.abs(action_m - amap(action)).max()))
        obs, _, terminated, _, _ = env.step(action[0])
        obs_m, _, terminated_m, _, _ = env_m.step(action_m[0])
        assert not terminated and not terminated_m
    return gaps, float(np.abs(env_m.data.qpos - state_mirror(body)[0](env.data.qpos)).max())


def test_the_mirrored_g1_expert_acts_as_the_mirrored_policy(g1, symmetric_g1):
    """The mirrored expert's action on the mirrored env is the mirror of the policy's on the
    original, step after step: on the symmetrised G1 the two rollouts stay each other's mirror
    images (float32 actions to 2e-5, qpos to 1e-5 after 10 steps, as the humanoid's), which
    proves the maps for the dynamics too. On Unitree's MJCF the first action agrees to the
    observation's 1e-5 m shoulder offset and then the rollouts drift apart by the MJCF's
    inertia and sole asymmetries (a few mm of qpos in 10 steps)."""
    gaps, qpos_gap = _rollouts(symmetric_g1)
    assert max(gaps) < 2e-5 and qpos_gap < 1e-5
    gaps, qpos_gap = _rollouts(g1)
    assert gaps[0] < 1e-4 and 1e-5 < qpos_gap < 2e-2
