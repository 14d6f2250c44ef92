"""Retargeting any reference motion onto the Unitree G1 (issue 25, item 3).

The source is a `ReferenceMotion` (a DeepMimic clip, a BVH through the importer, a video
reconstruction): the humanoid's pose per frame. The answer is, per frame, the G1's root pose
and 29 joint angles (`actors/motion/robot_motion.py`).

1. **The scaled source.** The source is sampled at its own frame rate; its root position is
   scaled by the ratio of the two bodies' standing pelvis heights, and every other key body is
   put at the end of a chain of the G1's own rest-pose bone vectors turned by the source's link
   rotations (pelvis -> hip -> knee -> ankle, pelvis -> torso -> shoulder -> elbow -> hand),
   i.e. the source's pose drawn with the robot's bone lengths and offsets. Its key bodies'
   orientations are the source links' rotations times the G1 body's rest rotation. The G1's rest
   pose is its zero pose with the elbows at 90 degrees (forearms down, as the humanoid's rest).
2. **Per-frame IK.** Damped Gauss-Newton over the G1's generalised coordinates (free root +
   29 hinges) with MuJoCo's kinematics and Jacobians (`mj_kinematics`, `mj_comPos`, `mj_jac`):
   position residuals of the key bodies (pelvis, torso, knees, feet, shoulders, elbows, hands),
   orientation residuals (pelvis, torso, feet, hands), a smoothness residual to the previous
   frame's answer (which is also the warm start), the ground: a foot the source has on the
   ground (the foot-contact rule of `actors/character/foot_contact.py`, or a video
   reconstruction's learned `contacts`) has its lowest point at z = 0 and its ankle held at the
   contact's mean position (no skating), and no collision geom may go below z = 0. Joint
   angles are clamped to the limits after every step. A last lift of the root removes any
   penetration left (zero by construction).
3. **The report.** Per-body position and orientation error against the scaled source, limit
   clipping, penetration and foot skating of the source, the scaled source and the robot.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import mujoco
import numpy as np

from actors.character import g1_spec as spec
from actors.character import quaternion as qn
from actors.character.foot_contact import CONTACT_BAND_M, FOOT_LINKS, LOW_QUANTILE, skating_speed, sole_heights
from actors.character.g1_model import kinematic_model
from actors.character.kinematics import forward_kinematics
from actors.character.skeleton import LINK_NAMES as SRC_LINKS
from actors.motion.reference_motion import ReferenceMotion
from actors.motion.robot_motion import RobotMotion

# (G1 body, chain parent (None: the root), source link whose rotation turns the bone from the
# parent, source link whose orientation the body takes (None: position only))
CHAIN: tuple[tuple[str, str | None, str | None, str | None], ...] = (
    ("pelvis", None, None, "root"),
    ("left_hip_pitch_link", "pelvis", "root", None),
    ("left_knee_link", "left_hip_pitch_link", "left_hip", None),
    ("left_ankle_roll_link", "left_knee_link", "left_knee", "left_ankle"),
    ("right_hip_pitch_link", "pelvis", "root", None),
    ("right_knee_link", "right_hip_pitch_link", "right_hip", None),
    ("right_ankle_roll_link", "right_knee_link", "right_knee", "right_ankle"),
    ("torso_link", "pelvis", "root", "chest"),
    ("left_shoulder_roll_link", "torso_link", "chest", None),
    ("left_elbow_link", "left_shoulder_roll_link", "left_shoulder", None),
    ("left_wrist_yaw_link", "left_elbow_link", "left_elbow", "left_wrist"),
    ("right_shoulder_roll_link", "torso_link", "chest", None),
    ("right_elbow_link", "right_shoulder_roll_link", "right_shoulder", None),
    ("right_wrist_yaw_link", "right_elbow_link", "right_elbow", "right_wrist"),
)
# The key bodies matched and reported (the hips sit at fixed offsets from the pelvis).
KEY_BODIES = tuple(name for name, *_ in CHAIN if "hip" not in name)
ORIENTED_BODIES = tuple(name for name, _, _, link in CHAIN if link is not None)
FOOT_BODIES = ("left_ankle_roll_link", "right_ankle_roll_link")
SRC_FEET = ("left_ankle", "right_ankle")
REST_POSE = {"left_elbow_joint": np.pi / 2, "right_elbow_joint": np.pi / 2}
# The IK's first guess: the rest pose with the elbows and knees a little bent, so that they
# start on the side they bend to (from a straight limb either side is a solution).
FIRST_GUESS_BEND = {"left_elbow_joint": -0.3, "right_elbow_joint": -0.3, "left_knee_joint": 0.3, "right_knee_joint": 0.3}
# The G1's elbows reach 30 degrees past straight (pi / 2); the humanoid's never go past straight,
# so the IK holds them within 5 degrees of it, as the G1's own knees are (a hyperextended,
# twisted arm is the other, wrong, solution for the same hand position).
ELBOW_HYPEREXTENSION_RAD = 0.087267
AT_LIMIT_RAD = 1e-4


@dataclass(frozen=True)
class RetargetSettings:
    position_weight: float = 1.0  # per metre
    orientation_weight: float = 0.25  # per radian (0.25: 0.1 rad weighs as 2.5 cm)
    smooth_weight: float = 0.05  # per unit of generalised coordinate change from the previous frame
    ground_weight: float = 5.0  # contact feet on the ground, collision geoms above it
    hold_weight: float = 3.0  # a contact foot's ankle at the contact's mean position (per metre)
    damping: float = 1e-4  # Levenberg-Marquardt lambda
    iterations: int = 25  # per frame (the first frame and a restart get 4x)
    restart_error_m: float = 0.03  # a key body further than this from its target: also try from the first guess
    tolerance: float = 1e-4  # stop when no coordinate moves more than this (m, rad)
    contact_band_m: float = 2 * CONTACT_BAND_M  # a source foot within this of its lowest height is on the ground


class G1Kinematics:
    """The G1's kinematic model with the index maps the retargeter needs."""

    def __init__(self, directory=None):
        self.model = kinematic_model(directory)
        m = self.model
        self.data = mujoco.MjData(m)
        self.body = {name: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name) for name in spec.LINK_NAMES}
        joint_ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n) for n in spec.JOINT_NAMES]
        self.qpos_adr = m.jnt_qposadr[joint_ids]
        self.dof_adr = m.jnt_dofadr[joint_ids]
        self.limits = m.jnt_range[joint_ids].copy()  # the robot's
        self.ik_limits = self.limits.copy()  # the IK's: the robot's, elbows not past straight
        for side in ("left", "right"):
            j = spec.JOINT_NAMES.index(f"{side}_elbow_joint")
            self.ik_limits[j, 1] = min(self.limits[j, 1], np.pi / 2 + ELBOW_HYPEREXTENSION_RAD)
        self.collision_geoms = np.array([g for g in range(m.ngeom)
                                         if (mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or "").endswith("_collision")])
        self.foot_geoms = {foot: np.array([g for g in self.collision_geoms if m.geom_bodyid[g] == self.body[foot]])
                           for foot in FOOT_BODIES}
        rest = self.rest_qpos()
        self.set(rest)
        self.rest_pos = {name: self.data.xpos[self.body[name]].copy() for name in spec.LINK_NAMES}
        self.rest_quat = {name: self.data.xquat[self.body[name]].copy() for name in spec.LINK_NAMES}
        self.rest_height = rest[2] - self.lowest_points(self.collision_geoms)[0].min()  # pelvis above the soles

    def rest_qpos(self) -> np.ndarray:
        qpos = np.zeros(self.model.nq)
        qpos[2], qpos[3] = 0.793, 1.0
        for name, angle in REST_POSE.items():
            qpos[self.qpos_adr[spec.JOINT_NAMES.index(name)]] = angle
        return qpos

    def set(self, qpos: np.ndarray) -> None:
        self.data.qpos[:] = qpos
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_comPos(self.model, self.data)

    def lowest_points(self, geoms: np.ndarray, xpos=None, xmat=None):
        """(n,) lowest z and (n, 3) lowest points of capsule / sphere geoms (world frame)."""
        m, d = self.model, self.data
        xpos = d.geom_xpos[geoms] if xpos is None else xpos
        xmat = d.geom_xmat[geoms].reshape(-1, 3, 3) if xmat is None else xmat
        radius = m.geom_size[geoms, 0]
        half = np.where(m.geom_type[geoms] == mujoco.mjtGeom.mjGEOM_CAPSULE, m.geom_size[geoms, 1], 0.0)
        axis = xmat[:, :, 2] * half[:, None]
        end = np.where((axis[:, 2] > 0)[:, None], xpos - axis, xpos + axis)
        point = end - np.array([0.0, 0.0, 1.0]) * radius[:, None]
        return point[:, 2], point

    def geoms_in_frame(self, geoms: np.ndarray, body: str, pos: np.ndarray, quat: np.ndarray):
        """World (xpos, xmat) of a body's geoms were the body at pos / quat (T, 3) / (T, 4)."""
        m = self.model
        body_mat = qn.quat_to_mat(quat)  # (T, 3, 3)
        local_mat = np.stack([qn.quat_to_mat(m.geom_quat[g]) for g in geoms])  # (n, 3, 3)
        xpos = pos[:, None, :] + np.einsum("tij,nj->tni", body_mat, m.geom_pos[geoms])
        xmat = np.einsum("tij,njk->tnik", body_mat, local_mat)
        return xpos, xmat


def _source_frames(motion: ReferenceMotion, fps: float | None):
    """Times and the humanoid's link positions / rotations sampled at a uniform rate."""
    fps = motion.fps if fps is None else fps
    count = max(2, int(round(motion.duration * fps)) + 1)
    times = np.arange(count) / fps
    times[-1] = min(times[-1], motion.duration)
    pose = motion.sample(times)
    pos, rot = forward_kinematics(pose.root_pos, pose.root_rot, pose.joint_rot)
    return times, fps, pos, rot


def scaled_source(kin: G1Kinematics, src_pos: np.ndarray, src_rot: np.ndarray, scale: float):
    """Key-body target positions {body: (T, 3)} and orientations {body: (T, 4)} (module doc, 1)."""
    pos, quat = {}, {}
    for body, parent, turn, oriented in CHAIN:
        if parent is None:
            pos[body] = src_pos[:, SRC_LINKS.index("root")] * scale
        else:
            bone = kin.rest_pos[body] - kin.rest_pos[parent]
            rotation = src_rot[:, SRC_LINKS.index(turn)]
            pos[body] = pos[parent] + qn.quat_rotate(rotation, np.broadcast_to(bone, rotation.shape[:-1] + (3,)))
        if oriented is not None:
            rest = np.broadcast_to(kin.rest_quat[body], src_rot.shape[:1] + (4,))
            quat[body] = qn.quat_normalize(qn.quat_mul(src_rot[:, SRC_LINKS.index(oriented)], rest))
    return pos, quat


def source_contacts(motion: ReferenceMotion, times: np.ndarray, src_pos: np.ndarray, band: float) -> np.ndarray:
    """(T, 2) bool, feet in FOOT_BODIES order (left, right): a video reconstruction's learned
    contacts when the clip carries them (right, left in the file), else the foot-contact rule."""
    learned = motion.extras.get("contacts")
    if learned is not None and np.shape(learned) == (motion.num_frames, 2):
        nearest = np.clip(np.searchsorted(motion.frame_times, times), 0, motion.num_frames - 1)
        return np.asarray(learned, bool)[nearest][:, ::-1]
    heights = src_pos[:, [SRC_LINKS.index(f) for f in SRC_FEET], 2]
    lowest = np.quantile(heights, LOW_QUANTILE, axis=0)
    return heights < lowest + band


def _segments(flags: np.ndarray):
    """(start, stop) of each run of True."""
    edges = np.flatnonzero(np.diff(np.concatenate(([0], flags.astype(np.int8), [0]))))
    return list(zip(edges[::2], edges[1::2]))


def _rotation_error(current: np.ndarray, target: np.ndarray, inverse: np.ndarray, delta: np.ndarray,
                    out: np.ndarray) -> np.ndarray:
    """World-frame rotation vector taking `target` to `current` (3,), with MuJoCo's quaternion ops."""
    mujoco.mju_negQuat(inverse, target)
    mujoco.mju_mulQuat(delta, current, inverse)
    if delta[0] < 0:
        delta *= -1.0
    mujoco.mju_quat2Vel(out, delta, 1.0)
    return out


class _Solver:
    """Damped Gauss-Newton with the joint limits as an active set: a joint at a limit that the
    step would push further out is held there and the step solved again without it."""

    def __init__(self, kin: G1Kinematics, settings: RetargetSettings):
        self.kin, self.s = kin, settings
        m = kin.model
        self.jacp = np.zeros((3, m.nv))
        self.jacr = np.zeros((3, m.nv))
        self.lo, self.hi = kin.ik_limits[:, 0], kin.ik_limits[:, 1]
        self.dof_adr = kin.dof_adr
        self.foot_geom_index = {foot: np.flatnonzero(np.isin(kin.collision_geoms, geoms))
                                for foot, geoms in kin.foot_geoms.items()}
        self._quat = (np.zeros(4), np.zeros(4), np.zeros(3))
        self._step = np.zeros(m.nv)
        self._eye = np.eye(m.nv)

    def _point_jac(self, point: np.ndarray, body: int) -> np.ndarray:
        mujoco.mj_jac(self.kin.model, self.kin.data, self.jacp, None, point, body)
        return self.jacp[2:3].copy()

    def residuals(self, qpos, prev, targets_pos, targets_quat, contact, contact_xy):
        kin, s, m, d = self.kin, self.s, self.kin.model, self.kin.data
        kin.set(qpos)
        rows, jacs = [], []
        for name in KEY_BODIES:
            b = kin.body[name]
            mujoco.mj_jacBody(m, d, self.jacp, None, b)
            foot = FOOT_BODIES.index(name) if name in FOOT_BODIES else -1
            if foot >= 0 and contact[foot]:  # held at the contact's mean ankle position; its height: the ground term
                rows.append(s.hold_weight * (d.xpos[b, :2] - contact_xy[foot]))
                jacs.append(s.hold_weight * self.jacp[:2])
            else:
                rows.append(s.position_weight * (d.xpos[b] - targets_pos[name]))
                jacs.append(s.position_weight * self.jacp)
        for name in ORIENTED_BODIES:
            b = kin.body[name]
            mujoco.mj_jacBody(m, d, None, self.jacr, b)
            rows.append(s.orientation_weight * _rotation_error(d.xquat[b], targets_quat[name], *self._quat).copy())
            jacs.append(s.orientation_weight * self.jacr)
        heights, points = kin.lowest_points(kin.collision_geoms)
        for foot_index, foot in enumerate(FOOT_BODIES):
            if contact[foot_index]:  # the foot's lowest point on the ground
                index = self.foot_geom_index[foot]
                k = index[int(np.argmin(heights[index]))]
                rows.append(s.ground_weight * heights[k:k + 1])
                jacs.append(s.ground_weight * self._point_jac(points[k], kin.body[foot]))
        for k in np.flatnonzero(heights < 0.0):  # nothing below the ground
            rows.append(s.ground_weight * heights[k:k + 1])
            jacs.append(s.ground_weight * self._point_jac(points[k], m.geom_bodyid[kin.collision_geoms[k]]))
        if prev is not None:
            mujoco.mj_differentiatePos(m, self._step, 1.0, prev, qpos)
            rows.append(s.smooth_weight * self._step)
            jacs.append(s.smooth_weight * self._eye)
        return np.concatenate(rows), np.concatenate(jacs)

    def solve(self, qpos: np.ndarray, prev: np.ndarray | None, targets_pos: dict, targets_quat: dict,
              contact: np.ndarray, contact_xy: np.ndarray, iterations: int) -> np.ndarray:
        kin, s, m = self.kin, self.s, self.kin.model
        qpos = qpos.copy()
        for _ in range(iterations):
            r, J = self.residuals(qpos, prev, targets_pos, targets_quat, contact, contact_xy)
            H, g = J.T @ J + s.damping * self._eye, J.T @ r
            joints = qpos[kin.qpos_adr]
            at_lo, at_hi = joints <= self.lo + AT_LIMIT_RAD, joints >= self.hi - AT_LIMIT_RAD
            free = np.ones(m.nv, dtype=bool)
            for _ in range(4):
                dq = np.zeros(m.nv)
                dq[free] = -np.linalg.solve(H[np.ix_(free, free)], g[free])
                step = dq[self.dof_adr]
                blocked = free[self.dof_adr] & ((at_lo & (step < 0)) | (at_hi & (step > 0)))
                if not blocked.any():
                    break
                free[self.dof_adr[blocked]] = False
            mujoco.mj_integratePos(m, qpos, dq, 1.0)
            qpos[kin.qpos_adr] = np.clip(qpos[kin.qpos_adr], self.lo, self.hi)
            if np.max(np.abs(dq)) < s.tolerance:
                break
        qpos[3:7] /= np.linalg.norm(qpos[3:7])
        return qpos

    def fit_error(self, qpos, targets_pos, targets_quat, contact, contact_xy) -> tuple[float, float]:
        """(sum of squared residuals without the smoothness term, worst key-body distance (m))."""
        r, _ = self.residuals(qpos, None, targets_pos, targets_quat, contact, contact_xy)
        free = [name for name in KEY_BODIES if name not in FOOT_BODIES or not contact[FOOT_BODIES.index(name)]]
        worst = max(float(np.linalg.norm(self.kin.data.xpos[self.kin.body[name]] - targets_pos[name])) for name in free)
        return float(r @ r), worst


def _lift_out_of_ground(kin: G1Kinematics, qpos: np.ndarray) -> np.ndarray:
    kin.set(qpos)
    lowest = kin.lowest_points(kin.collision_geoms)[0].min()
    if lowest < 0.0:
        qpos = qpos.copy()
        qpos[2] -= lowest
    return qpos


def fit_frames(kin: G1Kinematics, targets_pos: dict, targets_quat: dict, contacts: np.ndarray | None = None,
               contact_xy: np.ndarray | None = None, settings: RetargetSettings = RetargetSettings()) -> np.ndarray:
    """(T, nq) the G1's qpos per frame that best matches the key-body targets ({body: (T, 3)},
    {body: (T, 4)} for KEY_BODIES / ORIENTED_BODIES), each frame warm-started from the last."""
    count = len(targets_pos["pelvis"])
    contacts = np.zeros((count, 2), dtype=bool) if contacts is None else contacts
    contact_xy = np.zeros((count, 2, 2)) if contact_xy is None else contact_xy
    solver = _Solver(kin, settings)

    def first_guess(t: int) -> np.ndarray:
        qpos = kin.rest_qpos()
        for joint, bend in FIRST_GUESS_BEND.items():
            qpos[kin.qpos_adr[spec.JOINT_NAMES.index(joint)]] += bend
        qpos[:3] = targets_pos["pelvis"][t]
        qpos[3:7] = targets_quat["pelvis"][t]
        return qpos

    qpos = first_guess(0)
    frames = np.zeros((count, kin.model.nq))
    prev = None
    for t in range(count):
        frame = ({name: value[t] for name, value in targets_pos.items()},
                 {name: value[t] for name, value in targets_quat.items()}, contacts[t], contact_xy[t])
        iterations = settings.iterations * (4 if prev is None else 1)
        qpos = solver.solve(qpos, prev, frame[0], frame[1], frame[2], frame[3], iterations)
        cost, worst = solver.fit_error(qpos, *frame)
        if prev is not None and worst > settings.restart_error_m:
            # The warm start may be caught at the limits (an arm wound up through a cartwheel):
            # solve from the first guess too, without the pull to the previous frame, keep the better.
            # Only a clearly better fit is taken: a restart is a jump in the joint trajectory.
            fresh = solver.solve(first_guess(t), None, frame[0], frame[1], frame[2], frame[3], 4 * settings.iterations)
            fresh_cost, fresh_worst = solver.fit_error(fresh, *frame)
            if fresh_cost < cost and fresh_worst < 0.5 * worst:
                qpos = fresh
        qpos = _lift_out_of_ground(kin, qpos)
        frames[t] = qpos
        prev = qpos
    return frames


def retarget_to_g1(motion: ReferenceMotion, source_name: str | None = None, fps: float | None = None,
                   settings: RetargetSettings = RetargetSettings(), kin: G1Kinematics | None = None):
    """The G1 motion and the report (a dict of JSON-ready figures)."""
    started, cpu_started = time.perf_counter(), time.process_time()
    kin = G1Kinematics() if kin is None else kin
    times, fps, src_pos, src_rot = _source_frames(motion, fps)
    scale = float(kin.rest_height / _source_rest_height())
    targets_pos, targets_quat = scaled_source(kin, src_pos, src_rot, scale)
    contacts = source_contacts(motion, times, src_pos, settings.contact_band_m)
    contact_xy = np.zeros((len(times), 2, 2))
    for foot_index, foot in enumerate(FOOT_BODIES):
        xy = targets_pos[foot][:, :2]
        contact_xy[:, foot_index] = xy
        for start, stop in _segments(contacts[:, foot_index]):
            contact_xy[start:stop, foot_index] = xy[start:stop].mean(axis=0)
    frames = fit_frames(kin, targets_pos, targets_quat, contacts, contact_xy, settings)
    name = f"{motion.name}_g1"
    result = RobotMotion(character=spec.NAME, name=name, source=source_name or motion.source or motion.name, fps=float(fps),
                         loop=bool(motion.loop), joint_names=spec.JOINT_NAMES, root_pos=frames[:, :3].copy(),
                         root_quat=frames[:, 3:7].copy(), joint_pos=frames[:, kin.qpos_adr].copy(), contacts=contacts)
    report = retarget_report(kin, result, motion, src_pos, src_rot, targets_pos, targets_quat, scale)
    report["seconds"] = round(time.perf_counter() - started, 3)
    report["cpu_seconds"] = round(time.process_time() - cpu_started, 3)
    return result, report


def _source_rest_height() -> float:
    """The humanoid's standing root height above its soles."""
    zero = np.zeros((1, 3))
    identity = np.array([[1.0, 0.0, 0.0, 0.0]])
    pos, rot = forward_kinematics(zero[0], identity[0], np.tile(identity, (12, 1)))
    return float(-sole_heights(pos[None], rot[None]).min())


# ---------------------------------------------------------------------------- report
def robot_body_poses(kin: G1Kinematics, motion: RobotMotion):
    """{body: (T, 3)}, {body: (T, 4)} and (T,) lowest collision point of every frame."""
    pos = {name: np.zeros((motion.num_frames, 3)) for name in spec.LINK_NAMES}
    quat = {name: np.zeros((motion.num_frames, 4)) for name in spec.LINK_NAMES}
    lowest = np.zeros(motion.num_frames)
    qpos = motion.qpos()
    full = np.zeros((motion.num_frames, kin.model.nq))
    full[:, :7] = qpos[:, :7]
    full[:, kin.qpos_adr] = motion.joint_pos
    for t in range(motion.num_frames):
        kin.set(full[t])
        for name in spec.LINK_NAMES:
            pos[name][t] = kin.data.xpos[kin.body[name]]
            quat[name][t] = kin.data.xquat[kin.body[name]]
        lowest[t] = kin.lowest_points(kin.collision_geoms)[0].min()
    return pos, quat, lowest


def _r(x: float, digits: int = 4) -> float:
    return round(float(x), digits)


def retarget_report(kin, result: RobotMotion, motion: ReferenceMotion, src_pos, src_rot, targets_pos, targets_quat,
                    scale: float) -> dict:
    dt = 1.0 / result.fps
    pos, quat, lowest = robot_body_poses(kin, result)
    per_body = {}
    all_errors = []
    for name in KEY_BODIES:
        error = np.linalg.norm(pos[name] - targets_pos[name], axis=1)
        all_errors.append(error)
        entry = {"mean_m": _r(error.mean()), "max_m": _r(error.max())}
        if name in targets_quat:
            angle = np.degrees(qn.quat_angle(qn.quat_mul(quat[name], qn.quat_conj(targets_quat[name]))))
            entry["orientation_mean_deg"] = _r(angle.mean(), 2)
        per_body[name] = entry
    all_errors = np.stack(all_errors)
    joints = result.joint_pos
    at_limit = (joints <= kin.limits[:, 0] + AT_LIMIT_RAD) | (joints >= kin.limits[:, 1] - AT_LIMIT_RAD)
    clipped = {spec.JOINT_NAMES[j]: int(at_limit[:, j].sum()) for j in np.flatnonzero(at_limit.any(axis=0))}
    speeds = np.abs(np.diff(joints, axis=0)) / dt
    # Source feet: the humanoid's own soles and ankles; scaled: the G1 foot geoms on the target foot frames.
    src_heights = sole_heights(src_pos, src_rot)
    scaled_lowest = []
    for foot in FOOT_BODIES:
        geoms = kin.foot_geoms[foot]
        xpos, xmat = kin.geoms_in_frame(geoms, foot, targets_pos[foot], targets_quat[foot])
        z, _ = kin.lowest_points(np.tile(geoms, len(xpos)), xpos.reshape(-1, 3), xmat.reshape(-1, 3, 3))
        scaled_lowest.append(z.reshape(len(xpos), -1).min(axis=1))
    scaled_lowest = np.stack(scaled_lowest, axis=1)
    src_ankles = src_pos[:, list(FOOT_LINKS)]  # right, left
    scaled_ankles = np.stack([targets_pos[f] for f in FOOT_BODIES[::-1]], axis=1)
    robot_ankles = np.stack([pos[f] for f in FOOT_BODIES[::-1]], axis=1)
    held = (result.contacts[:-1] & result.contacts[1:])[:, ::-1]  # (T - 1, 2) right, left: down at both ends of the step

    def held_speed(ankles):  # mean horizontal ankle speed over the frames the source has the foot down
        speed = np.linalg.norm(np.diff(ankles[..., :2], axis=0), axis=-1) / dt
        return float(speed[held].mean()) if held.any() else 0.0

    source_skating = skating_speed(src_ankles, dt)
    scaled_skating = skating_speed(scaled_ankles, dt)
    robot_skating = skating_speed(robot_ankles, dt)
    return {
        "character": spec.NAME,
        "source": result.source,
        "frames": result.num_frames,
        "fps": _r(result.fps, 3),
        "loop": result.loop,
        "scale": _r(scale),
        "contact_frames": {"left": int(result.contacts[:, 0].sum()), "right": int(result.contacts[:, 1].sum())},
        "key_body_error_m": {"mean": _r(all_errors.mean()), "max": _r(all_errors.max()),
                             "worst_body": KEY_BODIES[int(np.argmax(all_errors.max(axis=1)))]},
        "per_body": per_body,
        "limit_clipping": {"joint_frames_at_limit": int(at_limit.sum()), "fraction": _r(at_limit.mean()),
                           "joints": clipped},
        "joint_speed": {"max_rad_s": _r(speeds.max(), 2), "fastest_joint": spec.JOINT_NAMES[int(np.argmax(speeds.max(axis=0)))],
                        "frames_over_motor_limit": int((speeds > spec.VELOCITY_LIMITS).any(axis=1).sum())},
        "penetration_m": {"source": _r(max(0.0, -src_heights.min())), "scaled_source": _r(max(0.0, -scaled_lowest.min())),
                          "robot": _r(max(0.0, -lowest.min()), 6)},
        "skating_m_s": {"source": _r(source_skating), "scaled_source": _r(scaled_skating), "robot": _r(robot_skating)},
        "skating_on_source_contacts_m_s": {"source": _r(held_speed(src_ankles)), "scaled_source": _r(held_speed(scaled_ankles)),
                                           "robot": _r(held_speed(robot_ankles))},
        "targets": {"key_body_error_le_0.05": bool(all_errors.mean() <= 0.05),
                    "zero_penetration": bool(lowest.min() >= -1e-9),
                    "skating_no_worse": bool(robot_skating <= scaled_skating + 1e-3)},
    }
