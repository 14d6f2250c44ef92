"""Retargeting onto the Unitree G1: a source whose answer is known, joint limits, the ground,
the report, and `sfv motion convert --character g1`.

The known answer: key-body targets drawn by the G1's own forward kinematics at known joint
angles; the IK must recover them. Tests that need the robot's model skip cleanly where
`sfv models fetch --robot g1` has not been run.
"""
import json
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest

from actors.character import g1_model, g1_spec
from actors.motion import robot_retarget as rr
from actors.motion.robot_motion import load_robot_motion

pytestmark = pytest.mark.skipif(not g1_model.model_available(), reason="G1 model not cached (sfv models fetch --robot g1)")


@pytest.fixture(scope="module")
def kin():
    return rr.G1Kinematics()


def _joint(name: str) -> int:
    return g1_spec.JOINT_NAMES.index(name)


def _poses(kin, count: int, seed: int, spread: float = 0.35, height: float = 0.9):
    """(count, nq) G1 poses: a smooth path between random poses within the IK's limits, pelvis up."""
    rng = np.random.default_rng(seed)
    lo, hi = kin.ik_limits[:, 0], kin.ik_limits[:, 1]
    centre = np.clip(np.array([0.0 if i not in (_joint("left_elbow_joint"), _joint("right_elbow_joint")) else 1.0
                               for i in range(g1_spec.NUM_JOINTS)]), lo, hi)
    ends = [np.clip(centre + rng.uniform(-spread, spread, g1_spec.NUM_JOINTS), lo + 0.02, hi - 0.02) for _ in range(2)]
    poses = np.zeros((count, kin.model.nq))
    for t, w in enumerate(np.linspace(0.0, 1.0, count)):
        poses[t, :3] = (0.1 * w, 0.0, height)
        yaw = 0.3 * w
        poses[t, 3:7] = (np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2))
        poses[t, kin.qpos_adr] = (1 - w) * ends[0] + w * ends[1]
    return poses


def _targets(kin, poses):
    pos = {name: np.zeros((len(poses), 3)) for name in rr.KEY_BODIES}
    quat = {name: np.zeros((len(poses), 4)) for name in rr.ORIENTED_BODIES}
    for t, qpos in enumerate(poses):
        kin.set(qpos)
        for name in pos:
            pos[name][t] = kin.data.xpos[kin.body[name]]
        for name in quat:
            quat[name][t] = kin.data.xquat[kin.body[name]]
    return pos, quat


def _key_body_errors(kin, frames, targets_pos):
    errors = []
    for t, qpos in enumerate(frames):
        kin.set(qpos)
        errors.append([np.linalg.norm(kin.data.xpos[kin.body[n]] - targets_pos[n][t]) for n in rr.KEY_BODIES])
    return np.array(errors)


@pytest.mark.parametrize("seed", [0, 1])
def test_a_source_drawn_by_the_g1_itself_is_recovered_within_1_cm(kin, seed):
    poses = _poses(kin, 8, seed)
    targets_pos, targets_quat = _targets(kin, poses)
    frames = rr.fit_frames(kin, targets_pos, targets_quat)
    errors = _key_body_errors(kin, frames, targets_pos)
    assert errors.max() < 0.01, errors.max()
    # Without the pull towards the previous frame the joint angles themselves come back.
    exact = rr.fit_frames(kin, targets_pos, targets_quat, settings=rr.RetargetSettings(smooth_weight=0.0, iterations=60))
    assert _key_body_errors(kin, exact, targets_pos).max() < 1e-3
    assert np.abs(exact[:, kin.qpos_adr] - poses[:, kin.qpos_adr]).max() < 0.01
    assert np.abs(exact[:, :3] - poses[:, :3]).max() < 1e-3


def test_targets_beyond_the_limits_give_angles_within_them(kin):
    poses = _poses(kin, 4, 2)
    beyond = poses.copy()
    beyond[:, kin.qpos_adr[_joint("left_ankle_roll_joint")]] = 0.6  # the limit is 0.2618
    beyond[:, kin.qpos_adr[_joint("right_knee_joint")]] = -0.5  # the limit is -0.087
    targets_pos, targets_quat = _targets(kin, beyond)
    frames = rr.fit_frames(kin, targets_pos, targets_quat)
    joints = frames[:, kin.qpos_adr]
    assert np.all(joints >= kin.limits[:, 0] - 1e-9) and np.all(joints <= kin.limits[:, 1] + 1e-9)
    assert np.allclose(joints[:, _joint("left_ankle_roll_joint")], kin.limits[_joint("left_ankle_roll_joint"), 1])


def test_a_source_below_the_floor_is_lifted_out_of_it(kin):
    poses = _poses(kin, 4, 3, height=0.65)  # the feet well below z = 0
    targets_pos, targets_quat = _targets(kin, poses)
    kin.set(poses[0])
    assert kin.lowest_points(kin.collision_geoms)[0].min() < -0.05
    frames = rr.fit_frames(kin, targets_pos, targets_quat)
    for qpos in frames:
        kin.set(qpos)
        assert kin.lowest_points(kin.collision_geoms)[0].min() >= -1e-9


def test_a_contact_foot_is_put_on_the_ground_and_held(kin):
    poses = _poses(kin, 6, 4, spread=0.15, height=0.83)
    targets_pos, targets_quat = _targets(kin, poses)
    contacts = np.zeros((6, 2), dtype=bool)
    contacts[:, 0] = True  # the left foot
    hold = targets_pos["left_ankle_roll_link"][:, :2].mean(axis=0)
    contact_xy = np.broadcast_to(np.stack([hold, np.zeros(2)]), (6, 2, 2)).copy()
    frames = rr.fit_frames(kin, targets_pos, targets_quat, contacts, contact_xy)
    left = kin.foot_geoms["left_ankle_roll_link"]
    ankle = []
    for qpos in frames:
        kin.set(qpos)
        assert abs(kin.lowest_points(left)[0].min()) < 0.003
        ankle.append(kin.data.xpos[kin.body["left_ankle_roll_link"], :2].copy())
    ankle = np.array(ankle)
    target_travel = np.linalg.norm(np.ptp(targets_pos["left_ankle_roll_link"][:, :2], axis=0))
    assert target_travel > 0.05  # the source foot slides; the robot's is held
    assert np.linalg.norm(np.ptp(ankle, axis=0)) < 0.3 * target_travel
    assert np.linalg.norm(ankle - hold, axis=1).max() < 0.02


def test_walk_meets_the_issue_targets_and_convert_writes_motion_and_report(walk_clip, tmp_path, capsys):
    from services.cli import main

    out = tmp_path / "walk_g1.npz"
    assert main(["motion", "convert", "deepmimic:walk", "--character", "g1", "--out", str(out)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("key-body error after scaling") and lines[-1].startswith(f"wrote {out}")
    report = json.loads(out.with_suffix(".json").read_text())["retarget"]
    motion = load_robot_motion(out, "g1")  # within the limits, or it would not load
    assert motion.num_frames == report["frames"] == walk_clip.num_frames and motion.loop
    assert report["key_body_error_m"]["mean"] <= 0.02 and report["key_body_error_m"]["max"] <= 0.08
    assert report["penetration_m"]["robot"] == 0.0 and report["penetration_m"]["source"] > 0.0
    assert report["skating_m_s"]["robot"] <= report["skating_m_s"]["scaled_source"]
    assert all(report["targets"].values())
    # The walk's feet alternate on the ground; both were held somewhere.
    assert motion.contacts[:, 0].any() and motion.contacts[:, 1].any()
    # The G1 walks forward as the humanoid does (scaled), not in place.
    assert motion.root_pos[-1, 0] - motion.root_pos[0, 0] == pytest.approx(
        report["scale"] * (walk_clip.root_pos[-1, 0] - walk_clip.root_pos[0, 0]), abs=0.05)


def test_the_model_we_build_has_our_actuators_and_the_xml_has_our_joints(kin):
    m = kin.model
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(1, m.njnt)]
    assert tuple(names) == g1_spec.JOINT_NAMES
    assert np.allclose(m.jnt_range[1:], g1_spec.JOINT_LIMITS)
    assert (m.nq, m.nv) == (36, 35) and abs(m.body_mass.sum() - 33.34) < 0.01
    mjcf = g1_model.build_g1_mjcf()
    full = mujoco.MjSpec.from_string(mjcf)  # parsed, not compiled (the meshes take seconds)
    actuators = {a.name: a for a in full.actuators}
    assert len(actuators) == 29
    knee = actuators["left_knee"]
    assert knee.gainprm[0] == pytest.approx(g1_spec.KP[_joint("left_knee_joint")], rel=1e-5)
    assert knee.forcerange[1] == pytest.approx(139.0)
    assert full.joint("left_knee_joint").armature == pytest.approx(g1_spec.ARMATURE[_joint("left_knee_joint")], rel=1e-5)
    assert full.geom("floor") is not None
    assert len(full.pairs) == len(g1_model.collision_geom_names(ET.fromstring(mjcf))) == 33
