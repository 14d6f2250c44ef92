"""BVH of a robot's motion: the compiled MJCF's kinematic tree as the hierarchy.

For the Unitree G1, and any `Character` compiled from MJCF whose joints are one free joint on
its root body and hinges (`sfv export RUN --bvh` of a robot run; the humanoid's own skeleton is
`bvh.py`'s). The conventions are `bvh.py`'s, so that BVH players and our own reader
(`bvh.read_bvh`, `bvh_pose.bvh_forward_kinematics`) take either file:

- Y up, the robot facing +x (MuJoCo's Z-up world turned as `bvh.zup_to_yup_*` turns it);
  centimetres by default (`units="cm"`) or metres; `Zrotation Xrotation Yrotation` channels
  in degrees (intrinsic Z, X, Y); one frame per motion frame, `Frame Time` 1 / fps.
- The hierarchy is the character's bodies in MuJoCo's own (depth-first) body order, each named
  as its body: ROOT the free joint's body (the G1's `pelvis`: `Xposition Yposition Zposition`,
  its world position, then three rotations), every other body a JOINT with three rotation
  channels, and each leaf an End Site at its centre of mass (`body_ipos`: the G1's feet and hands).
- A JOINT sits at its body's hinge anchor (the body's origin when the anchor is zero, as on every
  G1 joint) and its OFFSET is that point in the parent's frame: `body_pos + body_quat * anchor -
  parent anchor`. MuJoCo places a body at `x = x_parent + R_parent * body_pos`, turned by
  `R = R_parent * body_quat * R_hinge(q)` about the anchor, which therefore never moves in the
  parent's frame: the OFFSET is constant and the local rotation is `body_quat * R_hinge(q)` (the
  hinges of a body in MuJoCo's order; a body without a joint keeps `body_quat`). The BVH's
  forward kinematics then gives MuJoCo's `xanchor` (`xpos` for the G1) at every frame, up to
  the file's six decimals (`tests/actors/motion/test_robot_bvh.py` measures it).

Anything else (a slide or ball joint, a root without a free joint, hinges of one body with
different anchors) is one `SfvError` line naming the body.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from actors.character import quaternion as qn
from actors.motion.formats.bvh import (POSITION_CHANNELS, ROTATION_CHANNELS, UNITS, BvhJoint, bvh_text,
                                       quats_to_euler_deg, zup_to_yup_quat, zup_to_yup_vec)
from actors.motion.robot_motion import RobotMotion
from learner.atomic_io import atomic_write_bytes
from learner.errors import SfvError

_ANCHOR_TOLERANCE = 1e-9  # metres: the hinges of one body must share their anchor


@dataclass(frozen=True)
class RobotSkeleton:
    """The BVH hierarchy of a compiled robot, Z up and in metres (MuJoCo's), one row per body."""

    names: tuple[str, ...]  # body names, MuJoCo's body order (depth first: a parent before its children)
    body_ids: np.ndarray  # (B,) MuJoCo body ids
    parents: np.ndarray  # (B,) index of the parent row, -1 for the root
    offsets: np.ndarray  # (B, 3) the joint point in the parent's joint frame (the root's: 0)
    rest_quats: np.ndarray  # (B, 4) wxyz body_quat: the body's orientation in its parent at q = 0
    hinges: tuple[tuple[tuple[int, np.ndarray], ...], ...]  # per body: (qpos address, unit axis) of each hinge
    end_sites: tuple[np.ndarray | None, ...]  # leaves: the centre of mass in the joint frame
    root_qpos_adr: int  # the free joint's first qpos entry (position, then wxyz quaternion)


def _body_name(model: mujoco.MjModel, body: int) -> str:
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body) or f"body{body}"


def robot_skeleton(model: mujoco.MjModel, body_ids) -> RobotSkeleton:
    """The hierarchy of the bodies `body_ids` of `model` (a character's links; an arena's props left out)."""
    ids = sorted(int(b) for b in body_ids)
    rows = {body: row for row, body in enumerate(ids)}
    roots = [b for b in ids if model.body_parentid[b] not in rows]
    if len(roots) != 1:
        raise SfvError(f"robot BVH: the bodies have {len(roots)} roots ({', '.join(_body_name(model, b) for b in roots)}); one is needed")
    names, parents, offsets, rest, hinges, anchors = [], [], [], [], [], []
    root_qpos_adr = -1
    for body in ids:
        name = _body_name(model, body)
        joints = [j for j in range(model.body_jntadr[body], model.body_jntadr[body] + model.body_jntnum[body])]
        kinds = [int(model.jnt_type[j]) for j in joints]
        if body == roots[0]:
            if kinds != [mujoco.mjtJoint.mjJNT_FREE]:
                raise SfvError(f"robot BVH: the root body {name} needs one free joint (it has {len(joints)} joint(s) of other kinds)")
            root_qpos_adr = int(model.jnt_qposadr[joints[0]])
            parents.append(-1)
            anchors.append(np.zeros(3))
            hinges.append(())
        else:
            if any(kind != mujoco.mjtJoint.mjJNT_HINGE for kind in kinds):
                raise SfvError(f"robot BVH: body {name} has a joint that is not a hinge (only the root's may be free)")
            anchor = model.jnt_pos[joints[0]].copy() if joints else np.zeros(3)
            if any(np.abs(model.jnt_pos[j] - anchor).max() > _ANCHOR_TOLERANCE for j in joints):
                raise SfvError(f"robot BVH: the hinges of body {name} turn about different points")
            parents.append(rows[int(model.body_parentid[body])])
            anchors.append(anchor)
            hinges.append(tuple((int(model.jnt_qposadr[j]), model.jnt_axis[j] / np.linalg.norm(model.jnt_axis[j])) for j in joints))
        names.append(name)
        rest.append(qn.quat_normalize(model.body_quat[body].astype(np.float64)))
    for row, body in enumerate(ids):
        if parents[row] < 0:
            offsets.append(np.zeros(3))
        else:
            offsets.append(model.body_pos[body] + qn.quat_rotate(rest[row], anchors[row]) - anchors[parents[row]])
    leaves = set(range(len(ids))) - set(parents)
    end_sites = tuple(model.body_ipos[body] - anchors[row] if row in leaves else None for row, body in enumerate(ids))
    return RobotSkeleton(tuple(names), np.array(ids), np.array(parents), np.array(offsets), np.array(rest),
                         tuple(hinges), end_sites, root_qpos_adr)


def local_rotations(skeleton: RobotSkeleton, qpos: np.ndarray) -> np.ndarray:
    """(T, B, 4) wxyz rotation of each body in its parent's frame, MuJoCo's axes (the root's: its world rotation)."""
    qpos = np.asarray(qpos, np.float64)
    frames = len(qpos)
    out = np.empty((frames, len(skeleton.names), 4))
    for row, hinges in enumerate(skeleton.hinges):
        if skeleton.parents[row] < 0:
            out[:, row] = qn.quat_normalize(qpos[:, skeleton.root_qpos_adr + 3:skeleton.root_qpos_adr + 7])
            continue
        rotation = np.broadcast_to(skeleton.rest_quats[row], (frames, 4))
        for adr, axis in hinges:
            rotation = qn.quat_mul(rotation, qn.quat_about_axis(qpos[:, adr], axis))
        out[:, row] = rotation
    return out


def bvh_joints(skeleton: RobotSkeleton, scale: float) -> list[BvhJoint]:
    """The skeleton as `BvhJoint`s (Y up, file units; MuJoCo's body order is already depth first)."""
    joints = []
    for row, name in enumerate(skeleton.names):
        root = skeleton.parents[row] < 0
        end = skeleton.end_sites[row]
        joints.append(BvhJoint(name, int(skeleton.parents[row]), scale * zup_to_yup_vec(skeleton.offsets[row]) + 0.0,  # + 0: no -0.0
                               (POSITION_CHANNELS if root else ()) + ROTATION_CHANNELS,
                               None if end is None else scale * zup_to_yup_vec(end)))
    return joints


def robot_bvh_text(skeleton: RobotSkeleton, qpos: np.ndarray, fps: float, units: str = "cm") -> str:
    """The BVH file of `qpos` (T, nq) frames played at `fps`."""
    if units not in UNITS:
        raise SfvError(f"BVH units must be one of {', '.join(UNITS)}, got {units!r}")
    if not (np.isfinite(fps) and fps > 0):
        raise SfvError(f"robot BVH: fps must be a positive number, got {fps}")
    scale = UNITS[units]
    qpos = np.asarray(qpos, np.float64)
    root = skeleton.root_qpos_adr
    euler = quats_to_euler_deg(zup_to_yup_quat(local_rotations(skeleton, qpos)))  # (T, B, 3)
    frames = np.concatenate((scale * zup_to_yup_vec(qpos[:, root:root + 3]), euler.reshape(len(qpos), -1)), axis=1)
    return bvh_text(bvh_joints(skeleton, scale), frames, 1.0 / fps)


def robot_motion_qpos(motion: RobotMotion, compiled) -> tuple[RobotSkeleton, np.ndarray]:
    """The skeleton of `compiled` (a `CompiledCharacter`) and `motion`'s frames as its model's qpos (T, nq)."""
    character = compiled.character
    if motion.character != character.name or tuple(motion.joint_names) != tuple(character.joint_names):
        raise SfvError(f"{motion.name}: a motion of the {motion.character}'s {len(motion.joint_names)} joints, "
                       f"not of the {character.name}'s")
    skeleton = robot_skeleton(compiled.model, compiled.body_ids)
    qpos = np.tile(compiled.model.qpos0, (motion.num_frames, 1))
    qpos[:, skeleton.root_qpos_adr:skeleton.root_qpos_adr + 3] = motion.root_pos
    qpos[:, skeleton.root_qpos_adr + 3:skeleton.root_qpos_adr + 7] = motion.root_quat
    qpos[:, compiled.joint_qpos_adr] = motion.joint_pos
    return skeleton, qpos


def write_robot_bvh(motion: RobotMotion, compiled, path: str | os.PathLike, units: str = "cm") -> Path:
    """Write `motion` (a robot motion of `compiled`'s character) as BVH atomically (temp file, then rename)."""
    skeleton, qpos = robot_motion_qpos(motion, compiled)
    return atomic_write_bytes(path, robot_bvh_text(skeleton, qpos, motion.fps, units).encode("utf-8"))
