"""The character's full state in MuJoCo terms, and the vector ASI learns a distribution over.

`pose_to_qpos_qvel` maps a `MotionPose` onto MuJoCo's qpos / qvel (free root, ball joints
as quaternions, hinges as angles). The ASI state vector leaves out the root's horizontal
position (always taken from the reference at the sampled phase, so the Gaussians do not
have to learn where the clip is on the floor), in one of two coordinate systems:
- "rotvec" (the default): root height, root rotation and the 8 ball joints as rotation
  vectors (exponential coordinates), hinge angles, then qvel: 1 + 27 + 4 + 34 = 66 numbers.
  A diagonal Gaussian there perturbs each joint by a rotation of about sigma radians.
- "qpos" (SFV's literal state): `qpos[2:]` followed by `qvel`, 41 + 34 = 75 numbers, the
  quaternions' four entries perturbed independently and renormalised. A Gaussian over raw
  quaternion entries is not a rotation distribution: with the clip's per-entry std it tilts
  and twists joints far off any plausible pose (the per-step reward of ASI starts was .085
  against RSI's .12 at the start of training).
Rotation vectors wrap at pi: a root turned about half a turn from +x is represented near
the wrap, where a wide Gaussian can flip it (a rotation-space sample is still a valid pose).
"""
from __future__ import annotations

import numpy as np

from actors.character import quaternion as qn
from actors.character.humanoid3d import Humanoid

STATE_SPACES = ("rotvec", "qpos")


class StateLayout:
    """Index arrays that move a pose in and out of qpos / qvel without Python loops."""

    def __init__(self, humanoid: Humanoid, space: str = "qpos"):
        if space not in STATE_SPACES:
            raise ValueError(f"state space must be one of {STATE_SPACES}, got {space!r}")
        self.space = space
        self.nq, self.nv = humanoid.nq, humanoid.nv
        qadr, dadr = humanoid.joint_qpos_adr, humanoid.joint_dof_adr
        sph, rev = humanoid.character.joint_is_spherical, ~humanoid.character.joint_is_spherical
        self.hinge_axes = humanoid.character.hinge_axes  # (hinges, 3)
        self.num_joints = len(sph)
        self.ball_qpos = qadr[sph][:, None] + np.arange(4)  # (8, 4)
        self.ball_dof = dadr[sph][:, None] + np.arange(3)  # (8, 3)
        self.hinge_qpos = qadr[rev]  # (4,)
        self.hinge_dof = dadr[rev]
        self.spherical = np.flatnonzero(sph)
        self.revolute = np.flatnonzero(rev)
        # qpos indices of the quaternions (root, ball joints), in rotvec order.
        self._quat_qpos = np.concatenate((np.arange(3, 7)[None], self.ball_qpos))  # (9, 4)
        self._rotvec_rows = len(self._quat_qpos)
        if space == "qpos":
            self.state_dim = self.nq - 2 + self.nv
        else:
            self.state_dim = 1 + 3 * self._rotvec_rows + len(self.hinge_qpos) + self.nv
        # Quaternion slices inside the ASI state vector (renormalised after sampling); none
        # in rotation-vector coordinates, where every vector is a valid rotation.
        self.state_quat_slices = [slice(1, 5)] + [slice(a - 2, a + 2) for a in qadr[sph]] if space == "qpos" else []

    def pose_to_qpos_qvel(self, pose, qpos: np.ndarray, qvel: np.ndarray) -> None:
        qpos[0:3] = pose.root_pos
        qpos[3:7] = pose.root_rot
        qpos[self.ball_qpos] = pose.joint_rot[self.spherical]
        hinges = pose.joint_rot[self.revolute]
        qpos[self.hinge_qpos] = 2.0 * np.arctan2(np.einsum("...jk,jk->...j", hinges[..., 1:], self.hinge_axes), hinges[..., 0])  # signed angle about the axis
        qvel[0:3] = pose.root_lin_vel
        qvel[3:6] = pose.root_ang_vel
        qvel[self.ball_dof] = pose.joint_ang_vel[self.spherical]
        qvel[self.hinge_dof] = np.einsum("...jk,jk->...j", pose.joint_ang_vel[self.revolute], self.hinge_axes)

    def joint_quats_from_qpos(self, qpos: np.ndarray, out: np.ndarray) -> np.ndarray:
        """(joints, 4) local joint quaternions in skeleton order from a qpos vector."""
        out[self.spherical] = qpos[self.ball_qpos]
        half = 0.5 * qpos[self.hinge_qpos]
        out[self.revolute, 0] = np.cos(half)
        out[self.revolute, 1:] = np.sin(half)[:, None] * self.hinge_axes
        return out

    def state_vector(self, qpos: np.ndarray, qvel: np.ndarray) -> np.ndarray:
        if self.space == "qpos":
            return np.concatenate((qpos[2:], qvel))
        rotvecs = qn.quat_to_axis_angle(qpos[self._quat_qpos]).ravel()
        return np.concatenate((qpos[2:3], rotvecs, qpos[self.hinge_qpos], qvel))

    def transfer(self, qpos: np.ndarray, qvel: np.ndarray, from_qpos: np.ndarray, from_qvel: np.ndarray,
                 to_qpos: np.ndarray, to_qvel: np.ndarray) -> None:
        """Carry a state's deviation from one reference state onto another, in place.

        Rotations are perturbed in their own frame (q' = to from^-1 q: the same local offset
        from `to` as q has from `from`); positions, hinge angles and velocities add. A start
        drawn about the reference at one phase becomes the same perturbation at a nearby
        phase (ASI's components sit at k phases, the starts spread over their bins)."""
        quats = self._quat_qpos
        delta = qn.quat_mul(to_qpos[quats], qn.quat_conj(from_qpos[quats]))
        q = qpos[quats].copy()
        qpos[:3] += to_qpos[:3] - from_qpos[:3]
        qpos[self.hinge_qpos] += to_qpos[self.hinge_qpos] - from_qpos[self.hinge_qpos]
        qpos[quats] = qn.quat_normalize(qn.quat_mul(delta, q))
        qvel += to_qvel - from_qvel

    def apply_state_vector(self, state: np.ndarray, root_xy: np.ndarray, qpos: np.ndarray, qvel: np.ndarray) -> None:
        qpos[0:2] = root_xy
        if self.space == "rotvec":
            k = 1 + 3 * self._rotvec_rows
            qpos[2] = state[0]
            qpos[self._quat_qpos] = qn.quat_from_axis_angle(state[1:k].reshape(self._rotvec_rows, 3))
            qpos[self.hinge_qpos] = state[k:k + len(self.hinge_qpos)]
            qvel[:] = state[k + len(self.hinge_qpos):]
            return
        qpos[2:] = state[: self.nq - 2]
        qvel[:] = state[self.nq - 2:]
        for s in self.state_quat_slices:
            q = qpos[2:][s]
            qpos[2:][s] = q / max(np.linalg.norm(q), 1e-9)

