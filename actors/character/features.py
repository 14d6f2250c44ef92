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

from actors.character.humanoid3d import HUMANOID3D, Humanoid
from actors.character.state import StateLayout

REFERENCE_OBS_WIDTH = 3 + 4  # per observed reference step: root position and rotation in the heading frame


def obs_dim(character=HUMANOID3D) -> int:
    """Height, each link's position, rotation, linear and angular velocity, phase."""
    return 1 + character.num_links * (3 + 4 + 3 + 3) + 1


def pose_obs_width(character=HUMANOID3D) -> int:
    """Per observed step of the reference's pose: root height and link positions (actors/envs/reference_obs.py)."""
    return 1 + 3 * character.num_links


def observation_dim(reference_steps: int = 0, character=HUMANOID3D) -> int:
    """Observation width with `reference_steps` future reference roots (inserted before the phase)."""
    return obs_dim(character) + REFERENCE_OBS_WIDTH * reference_steps


def observation_layout(character=HUMANOID3D, reference_steps: int = 0, pose_steps: int = 0, scene_dim: int = 0,
                       heightmap_dim: int = 0) -> list[dict]:
    """The observation's blocks in order, each {name, start, size, what}: what `observations`
    writes (links in MuJoCo's body order 1..n, which for the humanoid3d is not
    `character.link_names`'s; everything in the root's heading frame), then the reference's
    poses ahead (`actors/envs/reference_obs.py`), a scene's vector and a terrain's heightmap
    (`actors/envs/ground.py`)."""
    n = character.num_links
    blocks = [("root_height", 1, "root height above the ground (m)"),
              ("link_positions", 3 * n, "each link's position relative to the root (m), x y z per link"),
              ("link_rotations", 4 * n, "each link's world rotation turned into the heading frame, w x y z per link, w >= 0"),
              ("link_linear_velocities", 3 * n, "each link's linear velocity (m/s)"),
              ("link_angular_velocities", 3 * n, "each link's angular velocity (rad/s)"),
              ("reference_root_positions", 3 * reference_steps, "the reference root K steps ahead relative to the root (m)"),
              ("reference_root_rotations", 4 * reference_steps, "the reference root's rotation K steps ahead, w x y z"),
              ("phase", 1, "the clip's phase in [0, 1]"),
              ("reference_poses", pose_steps * pose_obs_width(character), "per step ahead: the reference's root height and link positions"),
              ("scene", scene_dim, "the scene vector over its domain"),
              ("heightmap", heightmap_dim, "the ground's height less the root's at 16 x 5 points around the root in its heading frame "
                                           "(along -0.4..1.1 m by 0.1, across -0.3..0.3 m by 0.15; along-major)")]
    layout, start = [], 0
    for name, size, what in blocks:
        if size:
            layout.append({"name": name, "start": start, "size": size, "what": what})
        start += size
    return layout


@dataclass(frozen=True)
class RewardShape:
    """How many of each compared thing a character's `RewardFeatures` row holds: quaternions
    (the root's in the world, then each ball joint's), hinge angles, end effectors."""
    quats: int
    hinges: int
    end_effectors: int

    @classmethod
    def of(cls, character) -> "RewardShape":
        balls = int(character.joint_is_spherical.sum())
        return cls(1 + balls, len(character.joint_names) - balls, len(character.end_effector_links))

    @property
    def hinge_start(self) -> int:  # columns: quats, hinges, ang vel, end effectors, root, com
        return 4 * self.quats

    @property
    def ang_vel_start(self) -> int:
        return self.hinge_start + self.hinges

    def width(self, nv: int) -> int:
        """Columns of a row for a character with `nv` velocity coordinates."""
        return self.ang_vel_start + (nv - 3) + 3 * self.end_effectors + 4 * 3  # then root pos, root vel, com vel, com


# The humanoid3d's sizes, for the modules and tests that speak of it.
OBS_DIM = obs_dim(HUMANOID3D)  # 197
POSE_OBS_WIDTH = pose_obs_width(HUMANOID3D)  # 46
HUMANOID3D_REWARD_SHAPE = RewardShape.of(HUMANOID3D)
NUM_REWARD_QUATS = HUMANOID3D_REWARD_SHAPE.quats  # 9: root (world) + 8 ball joints (local); the 4 hinges compare angles
HINGE_START = HUMANOID3D_REWARD_SHAPE.hinge_start
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

    def __init__(self, values: np.ndarray, shape: RewardShape = HUMANOID3D_REWARD_SHAPE):
        self.values = values  # (B, D)
        self.shape = shape
        h, e = shape.hinges, shape.end_effectors
        n_ang = values.shape[1] - shape.width(3)
        ang, ee = shape.ang_vel_start, shape.ang_vel_start + n_ang
        root = ee + 3 * e
        # Named views, made once: the reward reads them every control step.
        self.quats = values[:, :shape.hinge_start].reshape(-1, shape.quats, 4)  # (B, 9, 4)
        self.hinges = values[:, shape.hinge_start:ang]  # (B, 4)
        self.ang_vel = values[:, ang:ee]  # (B, nv - 3)
        self.end_effectors = values[:, ee:root].reshape(-1, e, 3)  # (B, 4, 3)
        self.root_pos = values[:, root:root + 3]  # (B, 3) world
        self.root_xy = values[:, root:root + 2]
        self.root_lin_vel = values[:, root + 3:root + 6]  # (B, 3) world
        self.com_vel = values[:, root + 6:root + 9]  # (B, 3) world
        self.com = values[:, root + 9:root + 12]  # (B, 3) world
        self.com_xy = values[:, root + 9:root + 11]
        self.tail = values[:, shape.hinge_start:]  # everything compared by plain squared differences
        # Column ranges of `tail` (for the reward's weight matrices).
        t = root - shape.hinge_start
        self.tail_columns = {"hinges": (0, h), "ang_vel": (h, h + n_ang), "end_effectors": (h + n_ang, t),
                             "root_pos": (t, t + 3), "root_lin_vel": (t + 3, t + 6),
                             "com_vel": (t + 6, t + 9), "com": (t + 9, t + 12)}

    @classmethod
    def zeros(cls, nv: int, rows: int = 1, shape: RewardShape = HUMANOID3D_REWARD_SHAPE) -> "RewardFeatures":
        return cls(np.zeros((rows, shape.width(nv))), shape)

    def take(self, rows: np.ndarray, out: "RewardFeatures | None" = None) -> "RewardFeatures":
        """Rows gathered by index (a copy), e.g. each env's current reference row; into
        `out`'s buffer when given (the per-step path allocates nothing)."""
        if out is None:
            return RewardFeatures(self.values[rows], self.shape)
        np.take(self.values, rows, axis=0, out=out.values)
        return out

    def slice(self, rows: slice) -> "RewardFeatures":
        return RewardFeatures(self.values[rows], self.shape)


class FeatureExtractor:
    """Observation (197-D for humanoid3d) and reward features for `batch` envs, into fixed buffers.

    Per control step: `capture(i, data)` for each env, then `heading()` once, then
    `reward_features(yaw)` and `observations(phases, out, yaw)` over all rows.
    """

    def __init__(self, humanoid: Humanoid, batch: int = 1):
        self.model = humanoid.model
        self.batch = b = batch
        self.layout = StateLayout(humanoid)
        character = humanoid.character
        self.num_links = n = character.num_links
        self.obs_dim = obs_dim(character)
        self.reward_shape = RewardShape.of(character)
        self.root_body = int(humanoid.body_ids[0])
        # MuJoCo bodies 1..n are the links (see Humanoid); positions in that slice:
        self._ee = humanoid.body_ids[character.end_effector_links] - 1
        assert self.root_body == 1
        # qpos columns of the 9 reward quaternions then the 4 hinge angles, gathered in one go.
        quat_qpos = np.concatenate((np.arange(3, 7)[None], self.layout.ball_qpos))  # (9, 4)
        self._rot_qpos = np.concatenate((quat_qpos.ravel(), self.layout.hinge_qpos))
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
        self._ee_rel = np.zeros((b, len(self._ee), 3))
        self._ee_world = np.zeros((b, len(self._ee), 3))
        self._sign = np.zeros((b, n, 1))
        self._offset = np.zeros((b, 1, 3))
        self.sim = RewardFeatures.zeros(nv, b, self.reward_shape)
        self._make_views(b, n)

    def _make_views(self, b: int, n: int) -> None:
        """The slices and reshapes every step uses, made once: for a few envs, making a view
        costs about as much as the arithmetic on it."""
        yaw, half, ang = self._yaw, self._half, self.cvel[:, :, :3]
        self._heading_views = (self._theta, self.root_xmat[:, 0], self.root_xmat[:, 3], yaw[:, 0, 0], yaw[:, 1, 0],
                               yaw[:, 1, 1], yaw[:, 0, 1], half[:, 0, 0, 0], half[:, 1, 0, 0])
        self._reward_views = (self.sim.values[:, :self.reward_shape.ang_vel_start], self.qvel[:, 3:], self.pos[:, :1], self.pos[:, 0],
                              self.pos[:, :1, 2], self.sim.end_effectors[..., 2], self.qvel[:, :3])
        self._obs_views = (self.pos[:, 0, 2], self.pos[:, :1], self.com[:, None, :], self._offset, self._rel, ang,
                           ang[..., :, None], self._rel[..., None, :], self._outer, self._outer.reshape(b, n, 9),
                           self.cvel[:, :, 3:], self._lin, self._left, self._left.reshape(b, 16)[:, ::5],
                           half[:, 0, 0], half[:, 1], self._sign)
        self._out_views: tuple = (None,)  # the observation buffer last written and views into it

    def _observation_views(self, out: np.ndarray) -> tuple:
        """Views into an observation buffer: height, link positions, rotations, linear and
        angular velocities (the links' blocks one after the other), phase, reference roots."""
        b, n, end = out.shape[0], self.num_links, self.obs_dim - 1
        pos, rot, lin, ang = (out[:, 1 + start * n:1 + (start + width) * n] for start, width in ((0, 3), (3, 4), (7, 3), (10, 3)))
        rot = rot.reshape(b, n, 4)
        k = (out.shape[1] - self.obs_dim) // REFERENCE_OBS_WIDTH
        ref_pos = out[:, end:end + 3 * k].reshape(b, k, 3)
        ref_rot = out[:, end + 3 * k:end + 7 * k].reshape(b, k, 4)
        return (out, out[:, 0], pos.reshape(b, n, 3), rot, rot[..., :1], lin.reshape(b, n, 3), ang.reshape(b, n, 3),
                out[:, -1], ref_pos, ref_rot, ref_rot[..., :1], np.zeros((b, k, 3)), np.zeros((b, k, 1)))

    def capture(self, i: int, data: mujoco.MjData) -> None:
        """Copy env i's state (after `update_kinematics`) into row i."""
        bound, copies = self._copies[i]
        if bound is not data:
            # MjData's arrays are fixed views of its buffers: build the (row, field) pairs once.
            links = slice(1, self.num_links + 1)  # the walker's bodies; an arena's props come after them
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
            self._out_views = self._observation_views(out)
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

    def end_effector_positions(self) -> np.ndarray:
        """(B, E, 3) world positions of the captured rows' end effectors (a buffer, overwritten)."""
        return np.take(self.pos, self._ee, axis=1, out=self._ee_world)

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
