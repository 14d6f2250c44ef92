"""Retargeting a BVH clip from any rig onto the humanoid, step by step.

The method is the usual one of game and animation pipelines (copy *global* bone rotations
through a per-bone rest-pose offset, then re-derive local rotations on the target); the
DeepMimic paper (Peng et al. 2018, section 9) retargets its mocap by hand and does not
describe a procedure, so nothing here follows it.

1. Map (`actors/motion/formats/rigs.py`): each humanoid target names the source joint that drives it.
   Source joints no target names are never read: step 5 copies global rotations, so a
   collar, an extra spine joint or a twist bone folds into its mapped parent for free.
2. Source kinematics (`actors/motion/formats/bvh_pose.py`): global rotation G_j(t) and position p_j(t) of
   every source joint, and its rest position P_j (all rotations zero).
3. Axes: up is the rest skeleton's head (or neck, chest) minus the middle of its ankles;
   left is its left hip minus its right hip, made perpendicular to up; both are snapped to
   the nearest signed file axis; forward = left x up. The rotation C whose rows are
   (forward, left, up) carries file vectors into the humanoid's frame (x forward, y left,
   z up). `--up` / `--forward` override the detection.
4. Size: the rest skeleton's height (ankle to head along up) names the file's unit, the one
   of m, cm, mm, in, ft that makes it a human height (reported, and overridable, since
   BVH has no unit field). Positions are then scaled by the leg-length ratio s = humanoid
   leg / source leg (hip-knee-ankle at rest), so strides and root height fit the humanoid's
   legs rather than the performer's.
5. Rest offsets: both characters are assumed to stand upright facing forward at rest, but
   their limbs need not point the same way (T-pose, A-pose, the humanoid's arms-down pose).
   Per limb bone k, A_k is the shortest rotation taking the humanoid's rest bone direction
   onto the source's (C applied); for the feet only its turn about the vertical counts
   (both rest poses have the sole flat, whatever the ankle-to-toe slope); torso bones get
   A = identity. The humanoid's target global rotation is T_k(t) = C G_k(t) C^T A_k, so that
   T_k(t) d_k^humanoid = C G_k(t) d_k^source: each bone points where the source's points.
6. Local rotations, root first, in tree order: q_k = R_parent^-1 T_k with R_parent the
   parent's rotation *as retargeted*, so an error at one joint does not move its children's
   global orientation. Hinges (knees, elbows) keep the twist of q_k about their axis (the
   rest is reported as `off_axis_deg`) clipped to their range; ball joints are clipped to
   MuJoCo's cone (the largest of the joint's per-axis limits, which is what the simulated
   character enforces). The clipped amounts are reported per joint.
7. Root position: the middle of the source hips, C applied, times s (the humanoid's hips
   sit beside its root); the first frame's horizontal position is subtracted, as for
   DeepMimic clips.
8. Ground: the floor is put under the lowest sole (the foot boxes' lowest corners, ignoring
   the lowest 2 % of frames as glitches); frames whose sole would still be below it are
   lifted by that depth, so the feet never sink. Penetration (before, after) and foot
   skating (source, retargeted) are measured by `actors/character/foot_contact.py` and reported.
9. Loop: the clip is marked looping when its last pose is close to its first (joint angles
   within `LOOP_ANGLE_RAD` on average, root tilt within it too, root height within
   `LOOP_HEIGHT_M`): DeepMimic's cyclic clips end near, not exactly on, their first pose
   (the walk's arm swing differs by 0.5 rad, its mean joint by 0.11 rad).

Not done: foot IK (skating is measured, not removed), and per-bone length retargeting (only
rotations travel, so the humanoid keeps its own proportions by construction).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from actors.character import quaternion as qn
from actors.motion.formats.bvh import Bvh, end_site_yup
from actors.motion.formats.bvh_pose import bvh_forward_kinematics, rest_positions, rest_tip
from actors.motion.formats.bvh_units import AXES, UNIT_METRES
from actors.character.foot_contact import (
    LOW_QUANTILE,
    penetration_depth,
    skating_speed,
    sole_heights,
)
from actors.character.kinematics import forward_kinematics
from actors.motion.reference_motion import ReferenceMotion
from actors.motion.formats.rigs import RigMap
from actors.character.skeleton import (
    HINGE_AXIS,
    LINK_JOINT,
    LINK_NAMES,
    LINKS,
    NUM_JOINTS,
    NUM_LINKS,
    OFFSETS,
    PARENTS,
    joint_limits_zup,
    revolute_angle,
    yup_to_zup,
)
from learner.errors import SfvError

HUMAN_HEIGHT_M = 1.5  # ankle to head joint of an adult; only used to tell the units apart
LIMB_TIPS = {
    "right_hip": "right_knee", "right_knee": "right_ankle", "right_ankle": "right_toe",
    "left_hip": "left_knee", "left_knee": "left_ankle", "left_ankle": "left_toe",
    "right_shoulder": "right_elbow", "right_elbow": "right_wrist",
    "left_shoulder": "left_elbow", "left_elbow": "left_wrist",
}
FEET = ("right_ankle", "left_ankle")
LOOP_ANGLE_RAD = 0.2
LOOP_HEIGHT_M = 0.05


@dataclass(frozen=True)
class RetargetOptions:
    up: str | None = None  # "+y", "-z", ... (None: detect)
    forward: str | None = None
    units: str | None = None  # one of UNIT_METRES (None: detect); only reported, see step 4
    loop: bool | None = None  # None: detect (step 9)


# ------------------------------------------------------------------ humanoid rest
def _humanoid_rest() -> dict:
    """Rest positions (Z up, m) of the humanoid's links and of the tips `rigs.TARGETS` names."""
    pos = np.zeros((NUM_LINKS, 3))
    for link in range(1, NUM_LINKS):
        pos[link] = pos[PARENTS[link]] + OFFSETS[link]
    rest = {name: pos[i] for i, name in enumerate(LINK_NAMES)}
    for side in ("right", "left"):
        ankle = LINK_NAMES.index(f"{side}_ankle")
        rest[f"{side}_toe"] = pos[ankle] + yup_to_zup(end_site_yup(ankle))
    neck = LINK_NAMES.index("neck")
    rest["head"] = pos[neck] + yup_to_zup(end_site_yup(neck))
    return rest


HUMANOID_REST = _humanoid_rest()
HUMANOID_LEG_M = float(np.linalg.norm(OFFSETS[LINK_NAMES.index("right_knee")]) + np.linalg.norm(OFFSETS[LINK_NAMES.index("right_ankle")]))


# ----------------------------------------------------------------------- step 3
def _axis(spec: str, flag: str) -> np.ndarray:
    if spec not in AXES:
        raise SfvError(f"{flag} {spec}: expected one of {', '.join(AXES)}")
    return np.asarray(AXES[spec], np.float64)


def _snap(v: np.ndarray, exclude: np.ndarray | None = None) -> np.ndarray:
    """The signed unit axis nearest to v (never +-exclude)."""
    scores = np.abs(v).copy()
    if exclude is not None:
        scores[np.abs(exclude) > 0.5] = -1.0
    axis = int(np.argmax(scores))
    out = np.zeros(3)
    out[axis] = np.sign(v[axis]) or 1.0
    return out


def _axis_name(v: np.ndarray) -> str:
    return next(name for name, a in AXES.items() if np.allclose(a, v))


def file_basis(rest: dict, options: RetargetOptions, path) -> np.ndarray:
    """C (3x3): rows are the file's forward, left and up axes (step 3)."""
    feet = 0.5 * (rest["right_ankle"] + rest["left_ankle"])
    top = next(rest[k] for k in ("head", "neck", "chest", "root") if k in rest)
    up = _axis(options.up, "--up") if options.up else _snap(top - feet)
    if options.forward:
        forward = _axis(options.forward, "--forward")
        if abs(forward @ up) > 0.5:
            raise SfvError(f"--forward {options.forward}: must be perpendicular to the up axis {_axis_name(up)}")
        left = np.cross(up, forward)
    else:
        lateral = rest["left_hip"] - rest["right_hip"]
        lateral = lateral - (lateral @ up) * up
        if np.linalg.norm(lateral) < 1e-9:
            raise SfvError(f"{path}: the rest pose's hips coincide; give --forward")
        left = _snap(lateral, exclude=up)
        forward = np.cross(left, up)
    return np.stack((forward, left, up))


# ----------------------------------------------------------------------- step 4
def detect_units(height: float) -> str:
    return min(UNIT_METRES, key=lambda u: abs(np.log(max(height * UNIT_METRES[u], 1e-12) / HUMAN_HEIGHT_M)))


def _leg_length(rest: dict) -> float:
    sides = [np.linalg.norm(rest[f"{s}_knee"] - rest[f"{s}_hip"]) + np.linalg.norm(rest[f"{s}_ankle"] - rest[f"{s}_knee"])
             for s in ("right", "left")]
    return float(np.mean(sides))


# ----------------------------------------------------------------------- step 5
def _shortest_rotation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Unit quaternion of the smallest rotation taking direction a onto direction b."""
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    cross, dot = np.cross(a, b), float(a @ b)
    if dot < -1.0 + 1e-9:  # opposite: any perpendicular axis will do
        axis = np.cross(a, [1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.cross(a, [0.0, 1.0, 0.0])
        return np.concatenate(([0.0], axis / np.linalg.norm(axis)))
    return qn.quat_normalize(np.concatenate(([1.0 + dot], cross)))


def rest_offsets(source_rest: dict) -> dict:
    """A_k per mapped target (step 5); source_rest is in the humanoid's axes."""
    offsets = {}
    for target, tip in LIMB_TIPS.items():
        if target not in source_rest or tip not in source_rest:
            continue
        d_h = HUMANOID_REST[tip] - HUMANOID_REST[target]
        d_s = source_rest[tip] - source_rest[target]
        if target in FEET:
            d_h, d_s = d_h * [1, 1, 0], d_s * [1, 1, 0]
        if np.linalg.norm(d_s) > 1e-9 and np.linalg.norm(d_h) > 1e-9:
            offsets[target] = _shortest_rotation(d_h, d_s)
    return offsets


# ----------------------------------------------------------------------- step 6
def _clip_cone(q: np.ndarray, cone: float) -> tuple[np.ndarray, np.ndarray]:
    rotvec = qn.quat_to_axis_angle(q)
    angle = np.linalg.norm(rotvec, axis=-1, keepdims=True)
    scale = np.minimum(1.0, cone / np.maximum(angle, 1e-12))
    return qn.quat_from_axis_angle(rotvec * scale), (angle * (1.0 - scale))[..., 0]


def local_rotations(targets: dict, frames: int) -> tuple[np.ndarray, np.ndarray, dict, dict]:
    """Root rotation (T, 4), joint rotations (T, 12, 4), clipped and off-axis degrees (max per joint)."""
    world = np.empty((frames, NUM_LINKS, 4))
    joint_rot = np.empty((frames, NUM_JOINTS, 4))
    clipped, off_axis = {}, {}
    world[:, 0] = targets["root"]
    for link in range(1, NUM_LINKS):
        parent_world = world[:, PARENTS[link]]
        joint = LINK_JOINT[link]
        if joint < 0:  # welded wrist
            world[:, link] = parent_world
            continue
        name = LINK_NAMES[link]
        wanted = targets.get(name)
        local = np.tile(qn.IDENTITY, (frames, 1)) if wanted is None else qn.quat_mul(qn.quat_conj(parent_world), wanted)
        limits = joint_limits_zup(LINKS[link])
        if LINKS[link].joint == "revolute":
            angle = revolute_angle(local)
            twist = qn.quat_about_axis(angle, HINGE_AXIS)
            off_axis[name] = float(np.degrees(qn.quat_angle(qn.quat_mul(qn.quat_conj(twist), local)).max()))
            kept = np.clip(angle, limits[0, 0], limits[0, 1])
            local, excess = qn.quat_about_axis(kept, HINGE_AXIS), np.abs(angle - kept)
        else:
            local, excess = _clip_cone(local, float(np.abs(limits).max()))
        clipped[name] = float(np.degrees(excess.max()))
        joint_rot[:, joint] = local
        world[:, link] = qn.quat_mul(parent_world, local)
    return world[:, 0], qn.quat_normalize(joint_rot), clipped, off_axis


# ----------------------------------------------------------------------- step 8
def fit_ground(root_pos: np.ndarray, root_rot: np.ndarray, joint_rot: np.ndarray) -> tuple[np.ndarray, dict]:
    """Root positions with the floor under the soles, and the penetration before and after."""
    link_pos, link_rot = forward_kinematics(root_pos, root_rot, joint_rot)
    heights = sole_heights(link_pos, link_rot).min(axis=1)
    shift = -float(np.quantile(heights, LOW_QUANTILE))
    lift = np.maximum(0.0, -(heights + shift))
    fitted = root_pos.copy()
    fitted[:, 2] += shift + lift
    return fitted, {
        "floor_shift_m": round(shift, 6),
        "lifted_frames": int((lift > 0).sum()),
        "penetration_before_m": round(penetration_depth(heights), 6),
        "penetration_after_m": round(penetration_depth(heights + shift + lift), 6),
    }


def is_loop(root_pos: np.ndarray, root_rot: np.ndarray, joint_rot: np.ndarray) -> bool:
    angles = qn.quat_angle(qn.quat_mul(qn.quat_conj(joint_rot[0]), joint_rot[-1]))
    up = qn.quat_rotate(root_rot[[0, -1]], np.array([0.0, 0.0, 1.0]))
    tilt = np.arccos(np.clip(up[0] @ up[1], -1.0, 1.0))
    return bool(angles.mean() < LOOP_ANGLE_RAD and tilt < LOOP_ANGLE_RAD and abs(root_pos[0, 2] - root_pos[-1, 2]) < LOOP_HEIGHT_M)


# --------------------------------------------------------------------- together
@dataclass(frozen=True)
class SourceFrame:
    """How the source file sits against the humanoid (steps 3 and 4)."""

    index: dict  # target -> source joint index
    basis: np.ndarray  # C: file axes -> humanoid axes
    scale: float  # leg-length ratio, file units -> humanoid metres
    units: str
    height: float  # rest height in file units
    rest: dict  # target -> rest position, humanoid axes, file units

    def to_humanoid(self, positions: np.ndarray) -> np.ndarray:
        """File positions (..., 3) in humanoid axes and metres (not yet placed on the floor)."""
        return self.scale * positions @ self.basis.T


def source_frame(bvh: Bvh, rig: RigMap, options: RetargetOptions = RetargetOptions(), path="BVH") -> SourceFrame:
    index = {target: bvh.joint_index(source) for target, source in rig.joints.items()}
    rest_file = rest_positions(bvh)
    rest = {t: rest_file[i] for t, i in index.items()}
    for target, tip in LIMB_TIPS.items():  # an unmapped tip: the bone's own End Site or child
        if target in index and tip not in rest:
            end = rest_tip(bvh, index[target], rest_file)
            if end is not None:
                rest[tip] = end
    basis = file_basis(rest, options, path)
    source_rest = {t: basis @ p for t, p in rest.items()}
    top = source_rest[next(k for k in ("head", "neck", "chest", "root") if k in source_rest)][2]
    height = float(top - min(source_rest[k][2] for k in ("right_ankle", "left_ankle", "right_toe", "left_toe") if k in source_rest))
    if options.units is not None and options.units not in UNIT_METRES:
        raise SfvError(f"--units {options.units}: expected one of {', '.join(UNIT_METRES)}")
    source_leg = _leg_length(source_rest)
    if source_leg <= 1e-9:
        raise SfvError(f"{path}: the rest pose's legs have no length; cannot size the clip")
    return SourceFrame(index, basis, HUMANOID_LEG_M / source_leg, options.units or detect_units(height), height, source_rest)


def target_rotations(frame: SourceFrame, rotations: np.ndarray) -> dict:
    """Step 5: T_k(t) = C G_k(t) C^T A_k for every mapped humanoid link, (T, 4) each."""
    c_quat = Rotation.from_matrix(frame.basis).as_quat(scalar_first=True)
    offsets = rest_offsets(frame.rest)
    targets = {}
    for target, joint in frame.index.items():
        if target in LINK_NAMES:
            global_rot = qn.quat_mul(qn.quat_mul(c_quat, rotations[:, joint]), qn.quat_conj(c_quat))
            targets[target] = qn.quat_mul(global_rot, offsets[target]) if target in offsets else global_rot
    return targets


def root_positions(frame: SourceFrame, positions: np.ndarray) -> np.ndarray:
    """Step 7: the middle of the source hips in humanoid axes and size, starting above the origin."""
    hips = 0.5 * (positions[:, frame.index["right_hip"]] + positions[:, frame.index["left_hip"]])
    root_pos = frame.to_humanoid(hips)
    root_pos[:, :2] -= root_pos[0, :2]
    return root_pos


def retarget(bvh: Bvh, rig: RigMap, options: RetargetOptions = RetargetOptions(), path="BVH", name: str = "bvh"):
    """(ReferenceMotion, report dict) of a BVH clip retargeted onto the humanoid."""
    if len(bvh.frames) < 2:
        raise SfvError(f"{path}: a motion needs at least 2 frames, found {len(bvh.frames)}")
    frame = source_frame(bvh, rig, options, path)
    positions, rotations = bvh_forward_kinematics(bvh)
    root_rot, joint_rot, clipped, off_axis = local_rotations(target_rotations(frame, rotations), len(bvh.frames))
    root_pos, ground = fit_ground(root_positions(frame, positions), root_rot, joint_rot)
    loop = is_loop(root_pos, root_rot, joint_rot) if options.loop is None else options.loop
    dt = bvh.frame_time
    motion = ReferenceMotion(name, np.arange(len(bvh.frames)) * dt, root_pos, root_rot, joint_rot, loop)
    link_pos, _ = forward_kinematics(root_pos, root_rot, joint_rot)
    source_ankles = frame.to_humanoid(positions[:, [frame.index[f] for f in FEET]])
    report = {
        "rig": rig.name,
        "mapped": dict(rig.joints),
        "folded_joints": len(bvh.joints) - len(set(frame.index.values())),
        "up": _axis_name(frame.basis[2]), "forward": _axis_name(frame.basis[0]),
        "units": frame.units, "source_height_m": round(frame.height * UNIT_METRES[frame.units], 4),
        "leg_ratio": round(frame.scale / UNIT_METRES[frame.units], 6),
        "clipped_deg": {k: round(v, 3) for k, v in clipped.items() if v > 1e-6},
        "clipped_max_deg": round(max(clipped.values()), 3),
        "hinge_off_axis_deg": {k: round(v, 3) for k, v in off_axis.items()},
        **ground,
        "skating_source_mps": round(skating_speed(source_ankles, dt), 6),
        "skating_mps": round(skating_speed(link_pos[:, [LINK_NAMES.index(f) for f in FEET]], dt), 6),
        "loop": loop,
    }
    return motion, report
