"""Kinematic features of humanoid states, for B envs at once: observations and reward inputs.

The rollout hot path is per-env MuJoCo stepping followed by feature maths. Python-level numpy
calls cost about a microsecond each whatever their size, so the maths runs once per control
step over all B envs of a worker on (B, ...) arrays: each env only copies a few MjData fields
into its row (`capture`). A single env is the case B = 1. The reference (set into a scratch
MjData) goes through the same code, so perfect tracking gives exactly equal features.
"""
from __future__ import annotations

import mujoco
import numpy as np

from actors.character.humanoid import Humanoid
from actors.character.skeleton import END_EFFECTOR_LINKS, NUM_LINKS
from actors.character.state import StateLayout

OBS_DIM = 1 + NUM_LINKS * (3 + 4 + 3 + 3) + 1  # 197: height, link pos/rot/lin vel/ang vel, phase
REFERENCE_OBS_WIDTH = 3 + 4  # per observed reference step: root position and rotation in the heading frame
POSE_OBS_WIDTH = 1 + 3 * NUM_LINKS  # per observed step of the reference's pose: root height and link positions (actors/envs/reference_obs.py)


def observation_dim(reference_steps: int = 0) -> int:
    """Observation width with `reference_steps` future reference roots (inserted before the phase)."""
    return OBS_DIM + REFERENCE_OBS_WIDTH * reference_steps
NUM_REWARD_QUATS = 9  # root (world) + 8 ball joints (local); the 4 hinges compare angles
_POS = slice(1, 1 + 3 * NUM_LINKS)
_ROT = slice(_POS.stop, _POS.stop + 4 * NUM_LINKS)
_LIN = slice(_ROT.stop, _ROT.stop + 3 * NUM_LINKS)
_ANG = slice(_LIN.stop, _LIN.stop + 3 * NUM_LINKS)
HINGE_START = 4 * NUM_REWARD_QUATS  # RewardFeatures.values columns: quats, hinges, ang vel, end effectors, com
_ANG_VEL_START = HINGE_START + 4
# (w, x, y, z) @ P = (z, y, -x, -w): with c I + s P, the product conj(q_h) * q for q_h = (c, 0, 0, s).
# w x r as a linear map of the outer product w r^T (flattened row-major): two numpy calls
# instead of six products and a difference.
_CROSS_FROM_OUTER = np.zeros((9, 3))
for _i, (_j, _k) in enumerate(((1, 2), (2, 0), (0, 1))):
    _CROSS_FROM_OUTER[3 * _j + _k, _i], _CROSS_FROM_OUTER[3 * _k + _j, _i] = 1.0, -1.0
_HALF_YAW_PERMUTATION = np.array([[0, 0, 0, -1], [0, 0, -1, 0], [0, 1, 0, 0], [1, 0, 0, 0]], dtype=float)


def update_kinematics(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """Positions, centre of mass, body velocities and the centre of mass's velocity for the
    current qpos/qvel.

    mj_step leaves xpos / cvel at the state before its last integration; these three calls
    (much cheaper than mj_forward) bring them up to the state the policy will act on.
    """
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    mujoco.mj_comVel(model, data)
    mujoco.mj_subtreeVel(model, data)  # subtree_linvel[1]: the centre of mass's velocity (reward)


class RewardFeatures:
    """What the reward compares, with a leading batch (or table-row) dimension, stored as one
    flat (B, D) array so the reward's differences and sums are a few whole-row operations:
    9 quaternions (root in the world, 8 ball joints local), 4 hinge angles, the nv-3 angular
    velocity coordinates of qvel (root and ball joints in local frames, hinge rates), the 4
    end effectors (DeepMimic's: horizontal offset from the root and height above the ground,
    in the heading frame), the root's world position and linear velocity, and the world
    centre of mass's velocity and position."""

    def __init__(self, values: np.ndarray):
        self.values = values  # (B, D)
        n_ang = values.shape[1] - _ANG_VEL_START - 4 * 3 - 4 * 3
        ee = _ANG_VEL_START + n_ang
        # Named views, made once: the reward reads them every control step.
        self.quats = values[:, :HINGE_START].reshape(-1, NUM_REWARD_QUATS, 4)  # (B, 9, 4)
        self.hinges = values[:, HINGE_START:_ANG_VEL_START]  # (B, 4)
        self.ang_vel = values[:, _ANG_VEL_START:ee]  # (B, nv - 3)
        self.end_effectors = values[:, ee:ee + 12].reshape(-1, 4, 3)  # (B, 4, 3)
        self.root_pos = values[:, ee + 12:ee + 15]  # (B, 3) world
        self.root_xy = values[:, ee + 12:ee + 14]
        self.root_lin_vel = values[:, ee + 15:ee + 18]  # (B, 3) world
        self.com_vel = values[:, ee + 18:ee + 21]  # (B, 3) world
        self.com = values[:, ee + 21:ee + 24]  # (B, 3) world
        self.com_xy = values[:, ee + 21:ee + 23]
        self.tail = values[:, HINGE_START:]  # everything compared by plain squared differences
        # Column ranges of `tail` (for the reward's weight matrices).
        self.tail_columns = {"hinges": (0, 4), "ang_vel": (4, 4 + n_ang), "end_effectors": (4 + n_ang, 16 + n_ang),
                             "root_pos": (16 + n_ang, 19 + n_ang), "root_lin_vel": (19 + n_ang, 22 + n_ang),
                             "com_vel": (22 + n_ang, 25 + n_ang), "com": (25 + n_ang, 28 + n_ang)}

    @classmethod
    def zeros(cls, nv: int, rows: int = 1) -> "RewardFeatures":
        return cls(np.zeros((rows, _ANG_VEL_START + (nv - 3) + 4 * 3 + 4 * 3)))

    def take(self, rows: np.ndarray, out: "RewardFeatures | None" = None) -> "RewardFeatures":
        """Rows gathered by index (a copy), e.g. each env's current reference row; into
        `out`'s buffer when given (the per-step path allocates nothing)."""
        if out is None:
            return RewardFeatures(self.values[rows])
        np.take(self.values, rows, axis=0, out=out.values)
        return out

    def slice(self, rows: slice) -> "RewardFeatures":
        return RewardFeatures(self.values[rows])


class FeatureExtractor:
    """Observation (197-D) and reward features for `batch` envs, into fixed buffers.

    Per control step: `capture(i, data)` for each env, then `heading()` once, then
    `reward_features(yaw)` and `observations(phases, out, yaw)` over all rows.
    """

    def __init__(self, humanoid: Humanoid, batch: int = 1):
        self.model = humanoid.model
        self.batch = b = batch
        self.layout = StateLayout(humanoid)
        self.root_body = int(humanoid.body_ids[0])
        # MuJoCo bodies 1..15 are the links (see Humanoid); positions in that slice:
        self._ee = humanoid.body_ids[END_EFFECTOR_LINKS] - 1
        assert self.root_body == 1
        # qpos columns of the 9 reward quaternions then the 4 hinge angles, gathered in one go.
        quat_qpos = np.concatenate((np.arange(3, 7)[None], self.layout.ball_qpos))  # (9, 4)
        self._rot_qpos = np.concatenate((quat_qpos.ravel(), self.layout.hinge_qpos))
        n = NUM_LINKS
        nq, nv = self.model.nq, self.model.nv
        # Captured MjData fields, one row per env.
        self.pos = np.zeros((b, n, 3))
        self.quat = np.zeros((b, n, 4))
        self.cvel = np.zeros((b, n, 6))
        self.com = np.zeros((b, 3))
        self.com_vel = np.zeros((b, 3))
        self.root_xmat = np.zeros((b, 9))
        self.qpos = np.zeros((b, nq))
        self.qvel = np.zeros((b, nv))
        self._copies: list[tuple] = [((), None)] * b  # per row: (MjData it was bound to, ((dst, src), ...))
        # Scratch.
        self._theta = np.zeros(b)
        self._yaw = np.zeros((b, 3, 3))
        self._yaw[:, 2, 2] = 1.0
        self._half = np.zeros((b, 2, 1, 1))  # cos, sin of half each yaw
        self._left = np.zeros((b, 4, 4))
        self._rel = np.zeros((b, n, 3))
        self._lin = np.zeros((b, n, 3))
        self._outer = np.zeros((b, n, 3, 3))
        self._ee_rel = np.zeros((b, 4, 3))
        self._sign = np.zeros((b, n, 1))
        self._offset = np.zeros((b, 1, 3))
        self.sim = RewardFeatures.zeros(nv, b)
        self._make_views(b, n)

    def _make_views(self, b: int, n: int) -> None:
        """The slices and reshapes every step uses, made once: for a few envs, making a view
        costs about as much as the arithmetic on it."""
        yaw, half, ang = self._yaw, self._half, self.cvel[:, :, :3]
        self._heading_views = (self._theta, self.root_xmat[:, 0], self.root_xmat[:, 3], yaw[:, 0, 0], yaw[:, 1, 0],
                               yaw[:, 1, 1], yaw[:, 0, 1], half[:, 0, 0, 0], half[:, 1, 0, 0])
        self._reward_views = (self.sim.values[:, :_ANG_VEL_START], self.qvel[:, 3:], self.pos[:, :1], self.pos[:, 0],
                              self.pos[:, :1, 2], self.sim.end_effectors[..., 2], self.qvel[:, :3])
        self._obs_views = (self.pos[:, 0, 2], self.pos[:, :1], self.com[:, None, :], self._offset, self._rel, ang,
                           ang[..., :, None], self._rel[..., None, :], self._outer, self._outer.reshape(b, n, 9),
                           self.cvel[:, :, 3:], self._lin, self._left, self._left.reshape(b, 16)[:, ::5],
                           half[:, 0, 0], half[:, 1], self._sign)
        self._out_views: tuple = (None,)  # the observation buffer last written and views into it

    def capture(self, i: int, data: mujoco.MjData) -> None:
        """Copy env i's state (after `update_kinematics`) into row i."""
        bound, copies = self._copies[i]
        if bound is not data:
            # MjData's arrays are fixed views of its buffers: build the (row, field) pairs once.
            links = slice(1, NUM_LINKS + 1)  # the walker's bodies; an arena's props come after them
            copies = ((self.pos[i], data.xpos[links]), (self.quat[i], data.xquat[links]), (self.cvel[i], data.cvel[links]),
                      (self.com[i], data.subtree_com[1]), (self.com_vel[i], data.subtree_linvel[1]),
                      (self.root_xmat[i], data.xmat[1]),
                      (self.qpos[i], data.qpos), (self.qvel[i], data.qvel))
            self._copies[i] = (data, copies)
        for dst, src in copies:
            np.copyto(dst, src)

    def heading(self) -> np.ndarray:
        """(B,3,3) M with v_heading = v_world @ M (the inverse of each root's yaw); also keeps
        the cosine and sine of each half yaw for `observations`."""
        theta, fx, fy, c, s, c_copy, minus_s, half_c, half_s = self._heading_views
        np.arctan2(fy, fx, out=theta)  # yaw of the root's +x axis
        np.cos(theta, out=c)  # yaw = [[c, -s], [s, c]] in the top-left corner
        np.sin(theta, out=s)
        np.copyto(c_copy, c)
        np.negative(s, out=minus_s)
        theta *= 0.5
        np.cos(theta, out=half_c)
        np.sin(theta, out=half_s)
        yaw = self._yaw
        return yaw

    # ----------------------------------------------------------------- observation
    def observations(self, phases, out: np.ndarray, yaw: np.ndarray | None = None, reference: tuple | None = None) -> np.ndarray:
        """State features of SFV §9 / DeepMimic in each heading frame, plus the phase.

        `yaw` is this step's `heading()` (computed here when not given). `reference` =
        (positions (B, K, 3), quaternions (B, K, 4)) of K future reference roots in the world
        (MimicKit's target observation, root only): written before the phase as positions
        relative to the character's root and rotations, both in its heading frame, so the
        policy sees where the reference is (drift included), not only when (the phase)."""
        if yaw is None:
            yaw = self.heading()
        if self._out_views[0] is not out:
            b, n = out.shape[0], NUM_LINKS
            rot = out[:, _ROT].reshape(b, n, 4)
            k = (out.shape[1] - OBS_DIM) // REFERENCE_OBS_WIDTH
            ref_pos = out[:, OBS_DIM - 1:OBS_DIM - 1 + 3 * k].reshape(b, k, 3)
            ref_rot = out[:, OBS_DIM - 1 + 3 * k:OBS_DIM - 1 + 7 * k].reshape(b, k, 4)
            self._out_views = (out, out[:, 0], out[:, _POS].reshape(b, n, 3), rot, rot[..., :1],
                               out[:, _LIN].reshape(b, n, 3), out[:, _ANG].reshape(b, n, 3), out[:, -1],
                               ref_pos, ref_rot, ref_rot[..., :1], np.zeros((b, k, 3)), np.zeros((b, k, 1)))
        (_, out_height, out_pos, out_rot, out_rot_w, out_lin, out_ang, out_phase,
         out_ref_pos, out_ref_rot, out_ref_w, ref_rel, ref_sign) = self._out_views
        (height, root, com, offset, rel, ang, ang_col, lever_row, outer, outer_flat, lin_at_com, lin,
         left, left_diagonal, half_c, half_s, sign) = self._obs_views
        np.copyto(out_height, height)
        np.subtract(self.pos, root, out=rel)
        np.matmul(rel, yaw, out=out_pos)
        # Rotations: q_h^-1 * q for each yaw q_h = (cos th/2, 0, 0, sin th/2). Left-multiplying
        # by a fixed quaternion is linear, q @ (c I + s P) with P the product's signed
        # permutation; then w is made non-negative (q and -q are the same rotation).
        np.multiply(half_s, _HALF_YAW_PERMUTATION, out=left)
        left_diagonal += half_c
        np.matmul(self.quat, left, out=out_rot)
        np.copysign(1.0, out_rot_w, out=sign)
        out_rot *= sign
        if reference is not None and ref_rel.shape[1]:
            np.subtract(reference[0], root, out=ref_rel)
            np.matmul(ref_rel, yaw, out=out_ref_pos)
            np.matmul(reference[1], left, out=out_ref_rot)
            np.copysign(1.0, out_ref_w, out=ref_sign)
            out_ref_rot *= ref_sign
        # cvel is (angular, linear at the subtree centre of mass); move the linear part to
        # each body's origin: v = v_com + w x (p - com), the cross product as a linear map of
        # the outer product w r^T.
        np.subtract(root, com, out=offset)
        rel += offset  # now the lever p - com
        np.multiply(ang_col, lever_row, out=outer)
        np.matmul(outer_flat, _CROSS_FROM_OUTER, out=lin)
        lin += lin_at_com
        np.matmul(lin, yaw, out=out_lin)
        np.matmul(ang, yaw, out=out_ang)
        out_phase[...] = phases
        return out

    # ------------------------------------------------------------------- reward terms
    def reward_features(self, yaw: np.ndarray | None = None) -> RewardFeatures:
        """The reward's features of the captured rows (`self.sim`, overwritten each call)."""
        if yaw is None:
            yaw = self.heading()
        sim = self.sim
        rotations, qvel_rates, root, root_pos, root_height, ee_height, root_lin_vel = self._reward_views
        np.copyto(rotations, self.qpos.take(self._rot_qpos, axis=1))
        np.copyto(sim.ang_vel, qvel_rates)
        ee = np.subtract(self.pos.take(self._ee, axis=1), root, out=self._ee_rel)
        np.matmul(ee, yaw, out=sim.end_effectors)
        ee_height += root_height  # DeepMimic: height above the (flat) ground, not below the root
        np.copyto(sim.root_pos, root_pos)
        np.copyto(sim.root_lin_vel, root_lin_vel)
        np.copyto(sim.com_vel, self.com_vel)
        np.copyto(sim.com, self.com)
        return sim

    # ------------------------------------------------------------ single-env helpers
    def observation(self, data: mujoco.MjData, phase: float, out: np.ndarray, reference: tuple | None = None) -> np.ndarray:
        """Capture `data` into row 0 of a batch-of-one extractor and return its observation
        in `out`."""
        self.capture(0, data)
        return self.observations(phase, out if out.ndim == 2 else out.reshape(1, -1), reference=reference)[0]

    def reward_features_of(self, data: mujoco.MjData) -> RewardFeatures:
        """Capture `data` into row 0 of a batch-of-one extractor; its reward features."""
        self.capture(0, data)
        return self.reward_features()
