"""Forward kinematics (numpy and torch) against MuJoCo, and the quaternion helpers."""
import mujoco
import numpy as np
import pytest
import torch

from actors.character import quaternion as qn
from actors.character.humanoid3d import Humanoid
from actors.character.kinematics import forward_kinematics, revolute_angle
from actors.motion.reference_motion import MotionPose
from actors.character.skeleton import HINGE_AXIS, JOINT_IS_SPHERICAL, NUM_JOINTS, NUM_LINKS, REVOLUTE_JOINTS, SPHERICAL_JOINTS
from actors.character.state import StateLayout
from services.reconstruction import quaternion_torch as qt
from services.reconstruction.kinematics_torch import forward_kinematics_torch, joint_quats_from_params_torch

N_POSES = 20


def random_unit_quats(rng, shape):
    q = rng.normal(size=shape + (4,))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def random_pose(rng):
    """Root position and rotation anywhere, spherical joints any rotation, hinges any angle."""
    root_pos = rng.uniform(-2.0, 2.0, size=3)
    root_rot = random_unit_quats(rng, ())
    joint_rot = random_unit_quats(rng, (NUM_JOINTS,))
    angles = rng.uniform(-np.pi + 1e-3, np.pi - 1e-3, size=len(REVOLUTE_JOINTS))
    joint_rot[REVOLUTE_JOINTS] = qn.quat_about_axis(angles, HINGE_AXIS)
    return root_pos, root_rot, joint_rot


def same_rotation(a, b):
    """q and -q are the same rotation: compare up to the sign of each quaternion."""
    sign = np.where(np.sum(a * b, axis=-1, keepdims=True) < 0, -1.0, 1.0)
    return np.abs(a - sign * b).max()


@pytest.fixture(scope="module")
def humanoid():
    return Humanoid()


@pytest.fixture(scope="module")
def mujoco_poses(humanoid):
    """Random poses and MuJoCo's world link positions / rotations for each."""
    rng = np.random.default_rng(1234)
    layout = StateLayout(humanoid)
    data = mujoco.MjData(humanoid.model)
    out = []
    for _ in range(N_POSES):
        root_pos, root_rot, joint_rot = random_pose(rng)
        zeros3, zeros = np.zeros(3), np.zeros((NUM_JOINTS, 3))
        layout.pose_to_qpos_qvel(MotionPose(root_pos, root_rot, joint_rot, zeros3, zeros3, zeros), data.qpos, data.qvel)
        mujoco.mj_kinematics(humanoid.model, data)
        out.append((root_pos, root_rot, joint_rot, data.xpos[humanoid.body_ids].copy(), data.xquat[humanoid.body_ids].copy()))
    return out


def test_numpy_fk_matches_mujoco(mujoco_poses):
    for root_pos, root_rot, joint_rot, xpos, xquat in mujoco_poses:
        pos, rot = forward_kinematics(root_pos, root_rot, joint_rot)
        assert pos.shape == (NUM_LINKS, 3) and rot.shape == (NUM_LINKS, 4)
        np.testing.assert_allclose(pos, xpos, atol=1e-6, rtol=0)
        assert same_rotation(rot, xquat) < 1e-6


def test_numpy_fk_batched_equals_one_by_one(mujoco_poses):
    root_pos = np.stack([p[0] for p in mujoco_poses])
    root_rot = np.stack([p[1] for p in mujoco_poses])
    joint_rot = np.stack([p[2] for p in mujoco_poses])
    pos, rot = forward_kinematics(root_pos, root_rot, joint_rot)
    assert pos.shape == (N_POSES, NUM_LINKS, 3)
    np.testing.assert_allclose(pos, np.stack([p[3] for p in mujoco_poses]), atol=1e-6, rtol=0)
    assert same_rotation(rot, np.stack([p[4] for p in mujoco_poses])) < 1e-6


def test_torch_fk_matches_mujoco(mujoco_poses):
    root_pos = torch.tensor(np.stack([p[0] for p in mujoco_poses]))
    root_rot = torch.tensor(np.stack([p[1] for p in mujoco_poses]))
    joint_rot = torch.tensor(np.stack([p[2] for p in mujoco_poses]))
    pos, rot = forward_kinematics_torch(root_pos, root_rot, joint_rot)
    np.testing.assert_allclose(pos.numpy(), np.stack([p[3] for p in mujoco_poses]), atol=1e-6, rtol=0)
    assert same_rotation(rot.numpy(), np.stack([p[4] for p in mujoco_poses])) < 1e-6


def test_torch_fk_gradients_match_finite_differences():
    rng = np.random.default_rng(7)
    root_pos, root_rot, joint_rot = random_pose(rng)
    inputs = tuple(torch.tensor(a, requires_grad=True) for a in (root_pos, root_rot, joint_rot))
    pos, rot = forward_kinematics_torch(*inputs)
    (pos.sum() + rot.sum()).backward()
    assert all(x.grad is not None and torch.isfinite(x.grad).all() and x.grad.abs().sum() > 0 for x in inputs)
    assert torch.autograd.gradcheck(lambda *a: forward_kinematics_torch(*a), inputs, eps=1e-6, atol=1e-6, fast_mode=True)


def test_torch_fk_gradients_through_free_parameters():
    rng = np.random.default_rng(8)
    rotvecs = torch.tensor(rng.normal(scale=0.8, size=(2, len(SPHERICAL_JOINTS), 3)), requires_grad=True)
    angles = torch.tensor(rng.uniform(-2, 2, size=(2, len(REVOLUTE_JOINTS))), requires_grad=True)
    root_pos = torch.zeros(2, 3, dtype=torch.float64)
    root_rot = torch.tensor([[1.0, 0, 0, 0]] * 2, dtype=torch.float64)

    def link_positions(rv, an):
        return forward_kinematics_torch(root_pos, root_rot, joint_quats_from_params_torch(rv, an))[0]

    assert torch.autograd.gradcheck(link_positions, (rotvecs, angles), eps=1e-6, atol=1e-6, fast_mode=True)


def test_joint_quats_from_params_matches_numpy():
    rng = np.random.default_rng(3)
    rotvecs = rng.normal(size=(5, len(SPHERICAL_JOINTS), 3))
    rotvecs[0, 0] = 0.0  # the small-angle series branch
    angles = rng.uniform(-3, 3, size=(5, len(REVOLUTE_JOINTS)))
    quats = joint_quats_from_params_torch(torch.tensor(rotvecs), torch.tensor(angles)).numpy()
    assert quats.shape == (5, NUM_JOINTS, 4)
    np.testing.assert_allclose(quats[:, JOINT_IS_SPHERICAL], qn.quat_from_axis_angle(rotvecs), atol=1e-12)
    np.testing.assert_allclose(quats[:, ~JOINT_IS_SPHERICAL], qn.quat_about_axis(angles, HINGE_AXIS), atol=1e-12)
    np.testing.assert_allclose(revolute_angle(quats[:, ~JOINT_IS_SPHERICAL]), angles, atol=1e-12)


# ------------------------------------------------------------------ quaternion helpers
def test_quat_mul_and_rotate_match_mujoco():
    rng = np.random.default_rng(11)
    a, b = random_unit_quats(rng, (50,)), random_unit_quats(rng, (50,))
    v = rng.normal(size=(50, 3))
    product, rotated = np.zeros(4), np.zeros(3)
    for i in range(50):
        mujoco.mju_mulQuat(product, a[i], b[i])
        np.testing.assert_allclose(qn.quat_mul(a[i], b[i]), product, atol=1e-12)
        mujoco.mju_rotVecQuat(rotated, v[i], a[i])
        np.testing.assert_allclose(qn.quat_rotate(a[i], v[i]), rotated, atol=1e-12)
    np.testing.assert_allclose(qn.quat_rotate(a, v), np.einsum("nij,nj->ni", qn.quat_to_mat(a), v), atol=1e-12)
    np.testing.assert_allclose(qn.quat_mul(a, qn.quat_conj(a)), np.tile(qn.IDENTITY, (50, 1)), atol=1e-12)


def test_exp_log_round_trip_numpy():
    rng = np.random.default_rng(12)
    directions = rng.normal(size=(200, 3))
    directions /= np.linalg.norm(directions, axis=-1, keepdims=True)
    angles = np.concatenate((rng.uniform(0, np.pi - 1e-6, 196), [0.0, 1e-10, 1e-5, np.pi - 1e-9]))
    rotvecs = directions * angles[:, None]
    q = qn.quat_from_axis_angle(rotvecs)
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-12)
    np.testing.assert_allclose(qn.quat_to_axis_angle(q), rotvecs, atol=1e-9)
    np.testing.assert_allclose(qn.quat_angle(q), angles, atol=1e-7)
    # q and -q map to the same rotation vector.
    np.testing.assert_allclose(qn.quat_to_axis_angle(-q), rotvecs, atol=1e-9)
    # The rotation vector rotates vectors like MuJoCo's axis-angle quaternion does.
    mj = np.zeros(4)
    for rv in rotvecs[:20]:
        angle = np.linalg.norm(rv)
        if angle > 1e-6:
            mujoco.mju_axisAngle2Quat(mj, rv / angle, angle)
            assert same_rotation(qn.quat_from_axis_angle(rv), mj) < 1e-12


def test_exp_map_torch_matches_numpy_with_finite_gradient_at_zero():
    rng = np.random.default_rng(13)
    rotvecs = np.concatenate((rng.normal(size=(50, 3)), np.zeros((1, 3)), [[1e-6, 0, 0]]))
    q_torch = qt.quat_from_axis_angle(torch.tensor(rotvecs)).numpy()
    np.testing.assert_allclose(q_torch, qn.quat_from_axis_angle(rotvecs), atol=1e-12)
    zero = torch.zeros(3, dtype=torch.float64, requires_grad=True)
    qt.quat_from_axis_angle(zero).sum().backward()
    assert torch.isfinite(zero.grad).all()
    np.testing.assert_allclose(zero.grad.numpy(), [0.5, 0.5, 0.5], atol=1e-12)  # d(sin(|v|/2) v/|v|)/dv = I/2 at 0


def test_slerp_endpoints_and_midpoint():
    rng = np.random.default_rng(14)
    q0, q1 = random_unit_quats(rng, (30,)), random_unit_quats(rng, (30,))
    assert same_rotation(qn.quat_slerp(q0, q1, 0.0), q0) < 1e-12
    assert same_rotation(qn.quat_slerp(q0, q1, 1.0), q1) < 1e-12
    mid = qn.quat_slerp(q0, q1, 0.5)
    total = qn.quat_angle(qn.quat_mul(qn.quat_conj(q0), q1))
    np.testing.assert_allclose(qn.quat_angle(qn.quat_mul(qn.quat_conj(q0), mid)), total / 2, atol=1e-9)
    np.testing.assert_allclose(qn.quat_angle(qn.quat_mul(qn.quat_conj(mid), q1)), total / 2, atol=1e-9)
    # Nearly equal quaternions take the linear branch and stay unit.
    near = qn.quat_slerp(q0, qn.quat_normalize(q0 + 1e-9), 0.3)
    np.testing.assert_allclose(np.linalg.norm(near, axis=-1), 1.0, atol=1e-12)
    assert same_rotation(near, q0) < 1e-8


def test_torch_quaternion_helpers_match_numpy():
    rng = np.random.default_rng(15)
    a, b = random_unit_quats(rng, (40,)), random_unit_quats(rng, (40,))
    v = rng.normal(size=(40, 3))
    ta, tb, tv = torch.tensor(a), torch.tensor(b), torch.tensor(v)
    np.testing.assert_allclose(qt.quat_mul(ta, tb).numpy(), qn.quat_mul(a, b), atol=1e-12)
    np.testing.assert_allclose(qt.quat_rotate(ta, tv).numpy(), qn.quat_rotate(a, v), atol=1e-12)
    np.testing.assert_allclose(qt.quat_conj(ta).numpy(), qn.quat_conj(a), atol=0)
    np.testing.assert_allclose(qt.quat_normalize(ta * 3.0).numpy(), a, atol=1e-12)
    np.testing.assert_allclose(qt.quat_angle(ta).numpy(), qn.quat_angle(a), atol=1e-4)  # eps=1e-9 under the sqrt
    angles = rng.uniform(-3, 3, 40)
    np.testing.assert_allclose(qt.quat_about_axis(torch.tensor(angles), torch.tensor(HINGE_AXIS)).numpy(),
                               qn.quat_about_axis(angles, HINGE_AXIS), atol=1e-12)


def test_heading_of_a_yaw_rotation_is_its_angle():
    yaw = np.linspace(-3.0, 3.0, 13)
    q = qn.quat_about_axis(yaw, np.array([0.0, 0.0, 1.0]))
    np.testing.assert_allclose(qn.heading_angle(q), yaw, atol=1e-12)
    # A pitch on top of the yaw leaves the heading alone (the body's x axis keeps its yaw).
    pitched = qn.quat_mul(q, qn.quat_about_axis(np.full(13, 0.4), np.array([0.0, 1.0, 0.0])))
    np.testing.assert_allclose(qn.heading_angle(pitched), yaw, atol=1e-12)
