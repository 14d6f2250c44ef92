"""Kinematic features of humanoid states, for B envs at once: observations and reward inputs.

The rollout hot path is per-env MuJoCo stepping followed by feature maths. Python-level numpy
calls cost about a microsecond each whatever their size, so the maths runs once per control
step over all B envs of a worker on (B, ...) arrays: each env only copies a few MjData fields
into its row (`capture`). A single env is the case B = 1. The reference (set into a scratch
MjData) goes through the same code, so perfect tracking gives exactly equal features.
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
_POS = slice(1, 1 + 3 * NUM_LINKS)
_ROT = slice(_POS.stop, _POS.stop + 4 * NUM_LINKS)
_LIN = slice(_ROT.stop, _ROT.stop + 3 * NUM_LINKS)
_ANG = slice(_LIN.stop, _LIN.stop + 3 * NUM_LINKS)


def update_kinematics(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """Positions, centre of mass and body velocities for the current qpos/qvel.

    mj_step leaves xpos / cvel at the state before its last integration; these three calls
    (much cheaper than mj_forward) bring them up to the state the policy will act on.
    """
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    mujoco.mj_comVel(model, data)


@dataclass
class RewardFeatures:
    """What the reward compares, with a leading batch (or table-row) dimension: 9
    quaternions, 4 hinge angles, the nv-3 angular velocity coordinates of qvel (root and ball
    joints in local frames, hinge rates), the 4 end effectors relative to the root in the
    heading frame, and the world centre of mass."""

    quats: np.ndarray  # (B, 9, 4)
    hinges: np.ndarray  # (B, 4)
    ang_vel: np.ndarray  # (B, nv - 3)
    end_effectors: np.ndarray  # (B, 4, 3)
    com: np.ndarray  # (B, 3)

    @classmethod
    def zeros(cls, nv: int, rows: int = 1) -> "RewardFeatures":
        return cls(np.zeros((rows, NUM_REWARD_QUATS, 4)), np.zeros((rows, 4)), np.zeros((rows, nv - 3)), np.zeros((rows, 4, 3)), np.zeros((rows, 3)))

    def take(self, rows: np.ndarray) -> "RewardFeatures":
        """Rows gathered by index (copies), e.g. each env's current reference row."""
        return RewardFeatures(self.quats[rows], self.hinges[rows], self.ang_vel[rows], self.end_effectors[rows], self.com[rows])

    def slice(self, rows: slice) -> "RewardFeatures":
        return RewardFeatures(self.quats[rows], self.hinges[rows], self.ang_vel[rows], self.end_effectors[rows], self.com[rows])


class FeatureExtractor:
    """Observation (197-D) and reward features for `batch` envs, into fixed buffers."""

    def __init__(self, humanoid: Humanoid, batch: int = 1):
        self.model = humanoid.model
        self.batch = b = batch
        self.layout = StateLayout(humanoid)
        self.root_body = int(humanoid.body_ids[0])
        # MuJoCo bodies 1..15 are the links (see Humanoid); positions in that slice:
        self._ee = humanoid.body_ids[END_EFFECTOR_LINKS] - 1
        assert self.root_body == 1
        self.quat_qpos = np.concatenate((np.arange(3, 7)[None], self.layout.ball_qpos))  # (9, 4)
        n = NUM_LINKS
        nq, nv = self.model.nq, self.model.nv
        # Captured MjData fields, one row per env.
        self.pos = np.zeros((b, n, 3))
        self.quat = np.zeros((b, n, 4))
        self.cvel = np.zeros((b, n, 6))
        self.com = np.zeros((b, 3))
        self.forward = np.zeros((b, 2))  # world x, y of the root's +x axis
        self.qpos = np.zeros((b, nq))
        self.qvel = np.zeros((b, nv))
        # Scratch.
        self._yaw = np.zeros((b, 3, 3))
        self._yaw[:, 2, 2] = 1.0
        self._left = np.zeros((b, 4, 4))
        self._rel = np.zeros((b, n, 3))
        self._lin = np.zeros((b, n, 3))
        self._tmp = np.zeros((b, n, 3))
        self._c = np.zeros(b)
        self._s = np.zeros(b)
        self.sim = RewardFeatures.zeros(nv, b)

    def capture(self, i: int, data: mujoco.MjData) -> None:
        """Copy env i's state (after `update_kinematics`) into row i."""
        self.pos[i] = data.xpos[1:]
        self.quat[i] = data.xquat[1:]
        self.cvel[i] = data.cvel[1:]
        self.com[i] = data.subtree_com[1]
        xmat = data.xmat[1]
        self.forward[i, 0], self.forward[i, 1] = xmat[0], xmat[3]
        self.qpos[i] = data.qpos
        self.qvel[i] = data.qvel

    def _heading(self, rows: slice) -> np.ndarray:
        """(B,3,3) M with v_heading = v_world @ M (the inverse of each root's yaw)."""
        f = self.forward[rows]
        c, s = self._c[rows], self._s[rows]
        np.hypot(f[:, 0], f[:, 1], out=c)
        np.maximum(c, 1e-12, out=c)
        np.divide(f[:, 1], c, out=s)
        np.divide(f[:, 0], c, out=c)
        yaw = self._yaw[rows]
        yaw[:, 0, 0] = c
        yaw[:, 1, 1] = c
        yaw[:, 0, 1] = -s
        yaw[:, 1, 0] = s
        return yaw

    # ----------------------------------------------------------------- observation
    def observations(self, phases: np.ndarray, out: np.ndarray, rows: slice = slice(None)) -> np.ndarray:
        """State features of SFV §9 / DeepMimic in each heading frame, plus the phase."""
        pos, quat, cvel = self.pos[rows], self.quat[rows], self.cvel[rows]
        b, n = pos.shape[0], NUM_LINKS
        yaw = self._heading(rows)
        out[:, 0] = pos[:, 0, 2]
        rel = np.subtract(pos, pos[:, :1], out=self._rel[rows])
        np.matmul(rel, yaw, out=out[:, _POS].reshape(b, n, 3))
        self._heading_rotations(quat, yaw, out[:, _ROT].reshape(b, n, 4), rows)
        # cvel is (angular, linear at the subtree centre of mass); move the linear part to
        # each body's origin: v = v_com + w x (p - com).
        ang = cvel[:, :, :3]
        lever = rel
        lever += (pos[:, 0] - self.com[rows])[:, None, :]
        lin = self._cross(ang, lever, self._lin[rows], self._tmp[rows])
        lin += cvel[:, :, 3:]
        np.matmul(lin, yaw, out=out[:, _LIN].reshape(b, n, 3))
        np.matmul(ang, yaw, out=out[:, _ANG].reshape(b, n, 3))
        out[:, -1] = phases
        return out

    def _heading_rotations(self, quat: np.ndarray, yaw: np.ndarray, out: np.ndarray, rows: slice) -> None:
        """q_h^-1 * q for each yaw q_h = (cos th/2, 0, 0, sin th/2), one sign per rotation.

        Left-multiplying by a fixed quaternion is linear: one (15,4)@(4,4) product per env.
        """
        c, s = yaw[:, 0, 0], yaw[:, 1, 0]
        hc = np.sqrt(np.maximum(0.5 * (1.0 + c), 0.0))
        hs = np.copysign(np.sqrt(np.maximum(0.5 * (1.0 - c), 0.0)), s)
        m = self._left[rows]
        m[:, 0, 0] = m[:, 1, 1] = m[:, 2, 2] = m[:, 3, 3] = hc
        m[:, 3, 0] = m[:, 2, 1] = hs
        m[:, 1, 2] = m[:, 0, 3] = -hs
        np.matmul(quat, m, out=out)
        negative = out[..., 0] < 0
        if negative.any():
            out[negative] *= -1.0  # q and -q are the same rotation

    @staticmethod
    def _cross(a: np.ndarray, b: np.ndarray, out: np.ndarray, tmp: np.ndarray) -> np.ndarray:
        for i, (j, k) in enumerate(((1, 2), (2, 0), (0, 1))):
            np.multiply(a[..., j], b[..., k], out=out[..., i])
            np.multiply(a[..., k], b[..., j], out=tmp[..., i])
        out -= tmp
        return out

    # ------------------------------------------------------------------- reward terms
    def reward_features(self, rows: slice = slice(None)) -> RewardFeatures:
        """The reward's features of the captured rows (views into `self.sim`)."""
        sim = self.sim.slice(rows)
        qpos = self.qpos[rows]
        sim.quats[:] = qpos[:, self.quat_qpos]
        sim.hinges[:] = qpos[:, self.layout.hinge_qpos]
        sim.ang_vel[:] = self.qvel[rows, 3:]
        pos = self.pos[rows]
        ee = np.subtract(pos[:, self._ee], pos[:, :1], out=self._rel[rows, :4])
        np.matmul(ee, self._heading(rows), out=sim.end_effectors)
        sim.com[:] = self.com[rows]
        return sim

    # ------------------------------------------------------------ single-env helpers
    def observation(self, data: mujoco.MjData, phase: float, out: np.ndarray) -> np.ndarray:
        """Capture `data` into row 0 and return its (197,) observation in `out`."""
        self.capture(0, data)
        return self.observations(phase, out.reshape(1, -1), slice(0, 1))[0]

    def reward_features_of(self, data: mujoco.MjData) -> RewardFeatures:
        """Capture `data` into row 0; its reward features as a batch of one."""
        self.capture(0, data)
        return self.reward_features(slice(0, 1))
