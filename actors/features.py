"""Kinematic features of a MuJoCo humanoid state, shared by observations and rewards.

Both the simulated character and the reference (set into a scratch MjData) go through the
same functions, so a perfect tracking gives exactly equal features.
"""
from __future__ import annotations

import mujoco
import numpy as np

from actors.humanoid import Humanoid
from actors.skeleton import END_EFFECTOR_LINKS, HINGE_AXIS, NUM_LINKS
from actors.state import StateLayout

OBS_DIM = 1 + NUM_LINKS * (3 + 4 + 3 + 3) + 1  # 197: height, link pos/rot/lin vel/ang vel, phase
NUM_REWARD_ROTATIONS = 13  # root (world) + 12 joints (local)


def update_kinematics(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """Positions, centre of mass and body velocities for the current qpos/qvel.

    mj_step leaves xpos / cvel at the state before its last integration; these three calls
    (much cheaper than mj_forward) bring them up to the state the policy will act on.
    """
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    mujoco.mj_comVel(model, data)


def yaw_matrix_inverse(root_xmat: np.ndarray, out: np.ndarray) -> np.ndarray:
    """Rotation (3x3) from world into the character's heading frame (row vectors: v @ out)."""
    fx, fy = root_xmat[0], root_xmat[3]  # world x, y of the root's +x axis
    norm = np.hypot(fx, fy) or 1.0
    c, s = fx / norm, fy / norm
    out[0, 0], out[0, 1], out[1, 0], out[1, 1] = c, -s, s, c
    out[2, 2] = 1.0
    return out


class FeatureExtractor:
    """Computes the 197-D observation and the reward's kinematic terms into fixed buffers."""

    def __init__(self, humanoid: Humanoid):
        self.model = humanoid.model
        self.layout = StateLayout(humanoid)
        self.body_ids = humanoid.body_ids
        self.root_body = int(humanoid.body_ids[0])
        self.ee_body_ids = humanoid.body_ids[END_EFFECTOR_LINKS]
        self._yaw = np.zeros((3, 3))
        self._joint_quats = np.zeros((12, 4))

    # ----------------------------------------------------------------- observation
    def observation(self, data: mujoco.MjData, phase: float, out: np.ndarray) -> np.ndarray:
        """State features of SFV §9 / DeepMimic in the heading frame, plus the phase."""
        pos = data.xpos[self.body_ids]
        quat = data.xquat[self.body_ids]
        cvel = data.cvel[self.body_ids]
        root = pos[0].copy()
        yaw = yaw_matrix_inverse(data.xmat[self.root_body], self._yaw)
        c, s = yaw[0, 0], yaw[1, 0]
        n = NUM_LINKS
        out[0] = root[2]
        pos -= root
        out[1 : 1 + 3 * n] = (pos @ yaw).ravel()
        # Heading-frame rotation: q_h^-1 * q, with q_h^-1 = (cos(th/2), 0, 0, -sin(th/2)).
        half_c, half_s = np.sqrt(0.5 * (1 + c)), np.copysign(np.sqrt(0.5 * (1 - c)), s)
        w, x, y, z = quat[:, 0], quat[:, 1], quat[:, 2], quat[:, 3]
        rot = np.stack((half_c * w + half_s * z, half_c * x + half_s * y, half_c * y - half_s * x, half_c * z - half_s * w), axis=1)
        rot *= np.where(rot[:, :1] < 0, -1.0, 1.0)  # one sign per rotation: q and -q are the same
        out[1 + 3 * n : 1 + 7 * n] = rot.ravel()
        ang = cvel[:, :3]
        # cvel's linear part is at the subtree centre of mass; move it to each body's origin.
        lin = cvel[:, 3:] + np.cross(ang, pos + (root - data.subtree_com[self.root_body]))
        out[1 + 7 * n : 1 + 10 * n] = (lin @ yaw).ravel()
        out[1 + 10 * n : 1 + 13 * n] = (ang @ yaw).ravel()
        out[-1] = phase
        return out

    # ------------------------------------------------------------------- reward terms
    def reward_features(self, data: mujoco.MjData, rotations: np.ndarray, ang_vel: np.ndarray, end_effectors: np.ndarray, com: np.ndarray) -> None:
        """Fill (13,4) rotations, (13,3) local angular velocities, (4,3) heading-frame
        end-effector positions relative to the root, and the world centre of mass."""
        layout = self.layout
        qpos, qvel = data.qpos, data.qvel
        rotations[0] = qpos[3:7]
        layout.joint_quats_from_qpos(qpos, rotations[1:])
        ang_vel[0] = qvel[3:6]
        ang_vel[1 + layout.spherical] = qvel[layout.ball_dof]
        ang_vel[1 + layout.revolute] = qvel[layout.hinge_dof][:, None] * HINGE_AXIS
        yaw = yaw_matrix_inverse(data.xmat[self.root_body], self._yaw)
        end_effectors[:] = (data.xpos[self.ee_body_ids] - data.xpos[self.root_body]) @ yaw
        com[:] = data.subtree_com[self.root_body]
