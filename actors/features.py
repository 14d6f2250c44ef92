"""Kinematic features of a MuJoCo humanoid state, shared by observations and rewards.

Both the simulated character and the reference (set into a scratch MjData) go through the
same functions, so a perfect tracking gives exactly equal features. Everything writes into
preallocated buffers: this runs once per control step per env.
"""
from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from actors.humanoid import Humanoid
from actors.skeleton import END_EFFECTOR_LINKS, NUM_LINKS
from actors.state import StateLayout

OBS_DIM = 1 + NUM_LINKS * (3 + 4 + 3 + 3) + 1  # 197: height, link pos/rot/lin vel/ang vel, phase
NUM_REWARD_QUATS = 9  # root (world) + 8 ball joints (local); the 4 hinges compare angles


def update_kinematics(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """Positions, centre of mass and body velocities for the current qpos/qvel.

    mj_step leaves xpos / cvel at the state before its last integration; these three calls
    (much cheaper than mj_forward) bring them up to the state the policy will act on.
    """
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    mujoco.mj_comVel(model, data)


def yaw_matrix(root_xmat: np.ndarray, out: np.ndarray) -> np.ndarray:
    """M with v_heading = v_world @ M: the inverse of the root's yaw (Z up)."""
    fx, fy = root_xmat[0], root_xmat[3]  # world x, y of the root's +x axis
    norm = np.hypot(fx, fy) or 1.0
    c, s = fx / norm, fy / norm
    out[0, 0], out[0, 1], out[1, 0], out[1, 1] = c, -s, s, c
    out[2, 2] = 1.0
    return out


@dataclass
class RewardFeatures:
    """What the reward compares: 9 quaternions, 4 hinge angles, the 31 angular velocity
    coordinates of qvel (root and ball joints in local frames, hinge rates), the 4 end
    effectors relative to the root in the heading frame, and the world centre of mass."""

    quats: np.ndarray  # (..., 9, 4)
    hinges: np.ndarray  # (..., 4)
    ang_vel: np.ndarray  # (..., nv - 3)
    end_effectors: np.ndarray  # (..., 4, 3)
    com: np.ndarray  # (..., 3)

    @classmethod
    def zeros(cls, nv: int, rows: tuple = ()) -> "RewardFeatures":
        return cls(np.zeros(rows + (NUM_REWARD_QUATS, 4)), np.zeros(rows + (4,)), np.zeros(rows + (nv - 3,)), np.zeros(rows + (4, 3)), np.zeros(rows + (3,)))

    def row(self, k: int) -> "RewardFeatures":
        return RewardFeatures(self.quats[k], self.hinges[k], self.ang_vel[k], self.end_effectors[k], self.com[k])


class FeatureExtractor:
    """Computes the 197-D observation and the reward's features into fixed buffers."""

    def __init__(self, humanoid: Humanoid):
        self.model = humanoid.model
        self.layout = StateLayout(humanoid)
        self.root_body = int(humanoid.body_ids[0])
        self.ee_body_ids = humanoid.body_ids[END_EFFECTOR_LINKS]
        self.quat_qpos = np.concatenate((np.arange(3, 7)[None], self.layout.ball_qpos))  # (9, 4)
        n = NUM_LINKS
        self._links = slice(1, 1 + n)  # bodies 1..15 (see Humanoid)
        self._yaw = np.zeros((3, 3))
        self._rel = np.zeros((n, 3))
        self._lever = np.zeros((n, 3))
        self._lin = np.zeros((n, 3))
        self._tmp = np.zeros((n, 3))
        self._left = np.zeros((4, 4))  # right-multiplied matrix form of q_h^-1 * q
        self._ee = np.zeros((4, 3))
        self._pos_slice = slice(1, 1 + 3 * n)
        self._rot_slice = slice(1 + 3 * n, 1 + 7 * n)
        self._lin_slice = slice(1 + 7 * n, 1 + 10 * n)
        self._ang_slice = slice(1 + 10 * n, 1 + 13 * n)

    # ----------------------------------------------------------------- observation
    def observation(self, data: mujoco.MjData, phase: float, out: np.ndarray) -> np.ndarray:
        """State features of SFV §9 / DeepMimic in the heading frame, plus the phase."""
        n = NUM_LINKS
        pos, quat, cvel = data.xpos[self._links], data.xquat[self._links], data.cvel[self._links]
        root = data.xpos[self.root_body]
        yaw = yaw_matrix(data.xmat[self.root_body], self._yaw)
        out[0] = root[2]
        rel = np.subtract(pos, root, out=self._rel)
        np.matmul(rel, yaw, out=out[self._pos_slice].reshape(n, 3))
        self._heading_rotations(quat, yaw[0, 0], yaw[1, 0], out[self._rot_slice].reshape(n, 4))
        # cvel is (angular, linear at the subtree centre of mass); move the linear part to
        # each body's origin: v = v_com + w x (p - com).
        ang, lin_com = cvel[:, :3], cvel[:, 3:]
        lever = np.add(rel, root - data.subtree_com[self.root_body], out=self._lever)
        lin = self._cross(ang, lever, self._lin)
        lin += lin_com
        np.matmul(lin, yaw, out=out[self._lin_slice].reshape(n, 3))
        np.matmul(ang, yaw, out=out[self._ang_slice].reshape(n, 3))
        out[-1] = phase
        return out

    def _heading_rotations(self, quat: np.ndarray, c: float, s: float, out: np.ndarray) -> None:
        """q_h^-1 * q for the yaw q_h = (cos th/2, 0, 0, sin th/2), one sign per rotation.

        Left-multiplying by a fixed quaternion is linear, so it is one (15,4)@(4,4) product.
        """
        hc = np.sqrt(0.5 * (1.0 + c))
        hs = np.copysign(np.sqrt(max(0.5 * (1.0 - c), 0.0)), s)
        m = self._left
        m[0, 0] = m[1, 1] = m[2, 2] = m[3, 3] = hc
        m[3, 0], m[2, 1], m[1, 2], m[0, 3] = hs, hs, -hs, -hs
        np.matmul(quat, m, out=out)
        negative = out[:, 0] < 0
        if negative.any():
            out[negative] *= -1.0  # q and -q are the same rotation

    def _cross(self, a: np.ndarray, b: np.ndarray, out: np.ndarray) -> np.ndarray:
        tmp = self._tmp
        for i, (j, k) in enumerate(((1, 2), (2, 0), (0, 1))):
            np.multiply(a[:, j], b[:, k], out=out[:, i])
            np.multiply(a[:, k], b[:, j], out=tmp[:, i])
        out -= tmp
        return out

    # ------------------------------------------------------------------- reward terms
    def reward_features(self, data: mujoco.MjData, out: RewardFeatures) -> RewardFeatures:
        qpos = data.qpos
        out.quats[:] = qpos[self.quat_qpos]
        out.hinges[:] = qpos[self.layout.hinge_qpos]
        out.ang_vel[:] = data.qvel[3:]
        yaw = yaw_matrix(data.xmat[self.root_body], self._yaw)
        np.subtract(data.xpos[self.ee_body_ids], data.xpos[self.root_body], out=self._ee)
        np.matmul(self._ee, yaw, out=out.end_effectors)
        out.com[:] = data.subtree_com[self.root_body]
        return out
