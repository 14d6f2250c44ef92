"""The MuJoCo humanoid against the paper (§9) and DeepMimic's character facts."""
import json

import mujoco
import numpy as np
import pytest

from actors.character import quaternion as qn
from actors.character.humanoid3d import Humanoid
from actors.character.skeleton import JOINT_NAMES, LINK_NAMES, NUM_ACTUATED_DOF, yup_to_zup

PAPER_MASS_KG = 45.0
PAPER_HEIGHT_M = 1.62


@pytest.fixture(scope="module")
def humanoid():
    return Humanoid()


@pytest.fixture(scope="module")
def facts(shared_dir):
    """DeepMimic's character facts (conftest's `shared_dir` skips when ../shared is absent)."""
    return json.loads((shared_dir / "data" / "reference" / "humanoid3d_facts.json").read_text())


def name(model, kind, i):
    return mujoco.mj_id2name(model, kind, i)


def test_bodies_joints_and_actuators(humanoid):
    m = humanoid.model
    assert m.nbody == 1 + 15  # world + 13 jointed links + 2 welded hands
    assert [name(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in humanoid.body_ids] == list(LINK_NAMES)
    jointless = [name(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(1, m.nbody) if m.body_jntnum[b] == 0]
    assert sorted(jointless) == ["left_wrist", "right_wrist"]
    types = [m.jnt_type[j] for j in range(m.njnt)]
    assert types.count(mujoco.mjtJoint.mjJNT_FREE) == 1
    assert types.count(mujoco.mjtJoint.mjJNT_BALL) == 8
    assert types.count(mujoco.mjtJoint.mjJNT_HINGE) == 4
    hinges = sorted(name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(m.njnt) if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE)
    assert hinges == ["left_elbow", "left_knee", "right_elbow", "right_knee"]
    assert m.nu == NUM_ACTUATED_DOF == 28
    assert (m.nq, m.nv) == (7 + 8 * 4 + 4, 6 + 8 * 3 + 4)
    # Actuators: three per ball joint (x, y, z gears), then one per hinge, in skeleton order.
    actuated = [name(m, mujoco.mjtObj.mjOBJ_JOINT, m.actuator_trnid[a, 0]) for a in range(m.nu)]
    spherical = [n for n in JOINT_NAMES if not n.endswith(("knee", "elbow"))]
    revolute = [n for n in JOINT_NAMES if n.endswith(("knee", "elbow"))]
    assert actuated == [n for n in spherical for _ in range(3)] + revolute
    np.testing.assert_array_equal(m.actuator_gear[:24, :3], np.tile(np.eye(3), (8, 1)))


def test_total_mass_is_the_papers(humanoid):
    assert abs(mujoco.mj_getTotalmass(humanoid.model) - PAPER_MASS_KG) < 1e-6


def test_standing_height_is_the_papers(humanoid):
    """Top of the head minus the floor with every joint at identity (the standing pose)."""
    m = humanoid.model
    data = mujoco.MjData(m)
    mujoco.mj_forward(m, data)
    top, bottom = [], []
    for g in range(m.ngeom):
        if g == humanoid.floor_geom_id:
            continue
        size, rot = m.geom_size[g], data.geom_xmat[g].reshape(3, 3)
        if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
            half = np.abs(rot[2]) @ size
        elif m.geom_type[g] == mujoco.mjtGeom.mjGEOM_CAPSULE:
            half = size[0] + abs(rot[2, 2]) * size[1]
        else:
            half = size[0]
        top.append(data.geom_xpos[g, 2] + half)
        bottom.append(data.geom_xpos[g, 2] - half)
    assert max(top) == pytest.approx(PAPER_HEIGHT_M, abs=0.01)
    assert min(bottom) == pytest.approx(0.0, abs=0.002), "the feet rest on the floor"
    neck_geom = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "neck_geom")
    assert int(np.argmax(top)) + 1 == neck_geom, "the head is the highest point"


def test_standing_pose_holds_with_zero_targets(humanoid):
    m = humanoid.model
    data = mujoco.MjData(m)
    mujoco.mj_forward(m, data)
    start = data.qpos[:3].copy()
    mujoco.mj_step(m, data, nstep=int(2.0 / m.opt.timestep))
    assert np.isfinite(data.qpos).all()
    assert data.qpos[2] == pytest.approx(start[2], abs=0.01)
    assert np.linalg.norm(data.qpos[:2] - start[:2]) < 0.05
    assert np.abs(data.qvel).max() < 0.01


def test_gains_limits_masses_and_offsets_match_facts(humanoid, facts):
    m = humanoid.model
    joints = {j["name"]: j for j in facts["joints"]}
    for a in range(m.nu):
        joint = joints[name(m, mujoco.mjtObj.mjOBJ_JOINT, m.actuator_trnid[a, 0])]
        kp, kd = joint["kp_kd"]
        assert m.actuator_gainprm[a, 0] == kp and m.actuator_biasprm[a, 1] == -kp and m.actuator_biasprm[a, 2] == -kd
        assert tuple(m.actuator_forcerange[a]) == (-joint["torque_lim_Nm"], joint["torque_lim_Nm"])
        assert m.actuator_forcelimited[a]
    for j in range(1, m.njnt):
        fact = joints[name(m, mujoco.mjtObj.mjOBJ_JOINT, j)]
        if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE:
            assert fact["type"] == "revolute"
            np.testing.assert_allclose(m.jnt_range[j], fact["limits_rad"][0])
        else:
            assert fact["type"] == "spherical"
            np.testing.assert_allclose(m.jnt_range[j, 1], np.abs(fact["limits_rad"]).max(), rtol=1e-4)
    for body in facts["bodies"]:
        b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body["name"])
        assert m.body_mass[b] == pytest.approx(body["mass_kg"], abs=1e-9)
        fall_geom = m.body_geomadr[b] in humanoid.fall_geom_ids
        assert fall_geom == body["fall_contact"]
    for joint in facts["joints"][1:]:
        b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, joint["name"])
        np.testing.assert_allclose(m.body_pos[b], yup_to_zup(joint["attach_m"]), atol=1e-6)
    assert mujoco.mj_getTotalmass(m) == pytest.approx(facts["total_mass_kg"], abs=1e-6)


def test_geometry_matches_facts(humanoid, facts):
    """DeepMimic's Param0 of spheres and capsules is a diameter; boxes give full extents."""
    m = humanoid.model
    for body in facts["bodies"]:
        g = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, f"{body['name']}_geom")
        diameter, length, _ = body["params"]
        if body["shape"] == "sphere":
            assert m.geom_type[g] == mujoco.mjtGeom.mjGEOM_SPHERE
            assert m.geom_size[g, 0] == pytest.approx(diameter / 2)
        elif body["shape"] == "capsule":
            assert m.geom_type[g] == mujoco.mjtGeom.mjGEOM_CAPSULE
            assert tuple(m.geom_size[g, :2]) == pytest.approx((diameter / 2, length / 2))
        else:
            assert m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX
            ex, ey, ez = body["params"]  # Y-up extents: Z-up x, y, z are Y-up x, z, y
            assert tuple(2 * m.geom_size[g]) == pytest.approx((ex, ez, ey))
        np.testing.assert_allclose(m.geom_pos[g], yup_to_zup(body["attach_m"]), atol=1e-6)


def test_ball_actuator_length_is_the_exponential_coordinates(humanoid):
    """actions.py's premise: a ball joint's three actuators measure its rotation vector."""
    m = humanoid.model
    data = mujoco.MjData(m)
    rng = np.random.default_rng(5)
    ball_actuators = [a for a in range(m.nu) if m.jnt_type[m.actuator_trnid[a, 0]] == mujoco.mjtJoint.mjJNT_BALL]
    hinge_actuators = [a for a in range(m.nu) if a not in ball_actuators]
    for _ in range(10):
        mujoco.mj_resetData(m, data)
        for j in range(1, m.njnt):
            adr = m.jnt_qposadr[j]
            if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL:
                q = rng.normal(size=4)
                data.qpos[adr:adr + 4] = q / np.linalg.norm(q)
            else:
                data.qpos[adr] = rng.uniform(-3, 3)
        mujoco.mj_forward(m, data)
        for a in ball_actuators:
            adr = m.jnt_qposadr[m.actuator_trnid[a, 0]]
            rotvec = qn.quat_to_axis_angle(data.qpos[adr:adr + 4])
            assert data.actuator_length[a] == pytest.approx(m.actuator_gear[a, :3] @ rotvec, abs=1e-9)
        for a in hinge_actuators:
            assert data.actuator_length[a] == pytest.approx(data.qpos[m.jnt_qposadr[m.actuator_trnid[a, 0]]], abs=1e-12)


def test_actuators_are_clipped_pd_controllers(humanoid):
    m = humanoid.model
    data = mujoco.MjData(m)
    rng = np.random.default_rng(6)
    mujoco.mj_forward(m, data)
    data.qvel[6:] = rng.normal(scale=2.0, size=m.nv - 6)
    data.ctrl[:] = rng.uniform(-0.6, 0.6, size=m.nu)
    mujoco.mj_forward(m, data)
    kp, kd = m.actuator_gainprm[:, 0], -m.actuator_biasprm[:, 2]
    pd = kp * (data.ctrl - data.actuator_length) - kd * data.actuator_velocity
    expected = np.clip(pd, m.actuator_forcerange[:, 0], m.actuator_forcerange[:, 1])
    np.testing.assert_allclose(data.actuator_force, expected, atol=1e-9)
    assert (np.abs(pd) > m.actuator_forcerange[:, 1]).any(), "some torques were large enough to be clipped"
