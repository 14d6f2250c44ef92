"""A foreign rig for the retargeting tests: the humanoid's motion written through a skeleton
that differs in every way the retargeter must undo.

- other joint names (Mixamo's, or Unreal-style ones that need a map file);
- extra joints: a lower spine (with 6 channels, position ones included), collars, a head,
  toes, and two fingers per hand, all moving, none of them on the humanoid;
- an A-pose rest (arms `A_POSE_DEG` out from the humanoid's arms-down rest);
- a different size (`body_scale`) in centimetres;
- Z up facing -y, or Y up facing +z (Mixamo's convention);
- ZYX rotation channels (one joint XYZ).

Written independently of `actors/motion/formats/retarget.py`: each foreign joint's global rotation is the
humanoid link's global rotation times the inverse of that bone's known rest rotation (the
A-pose turn for the arms, identity elsewhere), and local rotations follow from the tree.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from actors.character import quaternion as qn
from actors.motion.formats.bvh import end_site_yup
from actors.character.kinematics import forward_kinematics
from actors.motion.reference_motion import ReferenceMotion
from actors.character.skeleton import LINK_NAMES, OFFSETS, yup_to_zup

A_POSE_DEG = 45.0

MIXAMO_NAMES = {
    "hips": "mixamorig:Hips", "spine": "mixamorig:Spine", "chest": "mixamorig:Spine1", "neck": "mixamorig:Neck",
    "head": "mixamorig:Head",
    **{f"{s}_{part}": f"mixamorig:{S}{name}" for s, S in (("right", "Right"), ("left", "Left")) for part, name in (
        ("collar", "Shoulder"), ("arm", "Arm"), ("forearm", "ForeArm"), ("hand", "Hand"), ("index1", "HandIndex1"),
        ("index2", "HandIndex2"), ("thumb", "HandThumb1"), ("upleg", "UpLeg"), ("leg", "Leg"), ("foot", "Foot"),
        ("toe", "ToeBase"))},
}
UNREAL_NAMES = {
    "hips": "pelvis", "spine": "spine_01", "chest": "spine_02", "neck": "neck_01", "head": "head",
    **{f"{s}_{part}": f"{name}_{s[0]}" for s in ("right", "left") for part, name in (
        ("collar", "clavicle"), ("arm", "upperarm"), ("forearm", "lowerarm"), ("hand", "hand"), ("index1", "index_01"),
        ("index2", "index_02"), ("thumb", "thumb_01"), ("upleg", "thigh"), ("leg", "calf"), ("foot", "foot"),
        ("toe", "ball"))},
}
CGSPEED_CMU_NAMES = {
    "hips": "hip", "spine": "abdomen", "chest": "chest", "neck": "neck", "head": "head",
    **{f"{s}_{part}": f"{s[0]}{name}" for s in ("right", "left") for part, name in (
        ("collar", "Collar"), ("arm", "Shldr"), ("forearm", "ForeArm"), ("hand", "Hand"), ("index1", "Index1"),
        ("index2", "Index2"), ("thumb", "Thumb1"), ("upleg", "Thigh"), ("leg", "Shin"), ("foot", "Foot"),
        ("toe", "Toe"))},
}
# The map file a user would write for UNREAL_NAMES (source joint: humanoid target).
UNREAL_MAP = {
    "pelvis": "root", "spine_02": "chest", "neck_01": "neck", "head": "head",
    **{f"{name}_{s[0]}": f"{s}_{target}" for s in ("right", "left") for name, target in (
        ("upperarm", "shoulder"), ("lowerarm", "elbow"), ("hand", "wrist"), ("thigh", "hip"), ("calf", "knee"),
        ("foot", "ankle"), ("ball", "toe"))},
}
FRAMES = {
    # rotation taking the humanoid's axes (x forward, y left, z up) to the file's
    "z_up": Rotation.from_euler("z", -90, degrees=True),  # forward -> -y
    "y_up": Rotation.from_matrix([[0, 1, 0], [0, 0, 1], [1, 0, 0]]),  # forward -> +z, up -> +y, left -> +x
}


def _link(name: str) -> int:
    return LINK_NAMES.index(name)


def _wobble(frames: int, amplitude_deg: float, axis, phase: float) -> np.ndarray:
    angle = np.radians(amplitude_deg) * np.sin(np.linspace(0, 4 * np.pi, frames) + phase)
    return qn.quat_about_axis(angle, np.asarray(axis, np.float64) / np.linalg.norm(axis))


def _skeleton(link_rot: np.ndarray, arm_out_deg: float) -> list[tuple]:
    """(role, parent role, rest offset (humanoid axes, m), global rotations (T, 4)) per joint."""
    frames = len(link_rot)
    H = lambda name: link_rot[:, _link(name)]
    joints = [
        ("hips", None, np.zeros(3), H("root")),
        ("spine", "hips", 0.5 * OFFSETS[_link("chest")], qn.quat_slerp(H("root"), H("chest"), 0.5)),
        ("chest", "spine", 0.5 * OFFSETS[_link("chest")], H("chest")),
        ("neck", "chest", OFFSETS[_link("neck")], H("neck")),
        ("head", "neck", yup_to_zup(end_site_yup(_link("neck"))), qn.quat_mul(H("neck"), _wobble(frames, 15, (0, 1, 0), 0.3))),
    ]
    for side, sign in (("right", -1.0), ("left", 1.0)):
        a_pose = qn.quat_about_axis(np.radians(sign * arm_out_deg), np.array([1.0, 0.0, 0.0]))
        undo = qn.quat_conj(a_pose)
        arm_down = lambda v, a_pose=a_pose: qn.quat_rotate(a_pose, v)
        shoulder = OFFSETS[_link(f"{side}_shoulder")]
        hand = qn.quat_mul(qn.quat_mul(H(f"{side}_elbow"), undo), _wobble(frames, 25, (1, 0, 0), 1.0))
        joints += [
            (f"{side}_collar", "chest", 0.4 * shoulder, qn.quat_mul(H("chest"), _wobble(frames, 10, (1, 0, 0), sign))),
            (f"{side}_arm", f"{side}_collar", 0.6 * shoulder, qn.quat_mul(H(f"{side}_shoulder"), undo)),
            (f"{side}_forearm", f"{side}_arm", arm_down(OFFSETS[_link(f"{side}_elbow")]), qn.quat_mul(H(f"{side}_elbow"), undo)),
            (f"{side}_hand", f"{side}_forearm", arm_down(OFFSETS[_link(f"{side}_wrist")]), hand),
            (f"{side}_index1", f"{side}_hand", arm_down(np.array([0.02, 0.0, -0.08])), qn.quat_mul(hand, _wobble(frames, 30, (0, 1, 0), 0.0))),
            (f"{side}_index2", f"{side}_index1", arm_down(np.array([0.0, 0.0, -0.03])), qn.quat_mul(hand, _wobble(frames, 40, (0, 1, 0), 0.5))),
            (f"{side}_thumb", f"{side}_hand", arm_down(np.array([0.03, sign * 0.02, -0.03])), qn.quat_mul(hand, _wobble(frames, 20, (1, 0, 0), 0.2))),
            (f"{side}_upleg", "hips", OFFSETS[_link(f"{side}_hip")], H(f"{side}_hip")),
            (f"{side}_leg", f"{side}_upleg", OFFSETS[_link(f"{side}_knee")], H(f"{side}_knee")),
            (f"{side}_foot", f"{side}_leg", OFFSETS[_link(f"{side}_ankle")], H(f"{side}_ankle")),
            (f"{side}_toe", f"{side}_foot", yup_to_zup(end_site_yup(_link(f"{side}_ankle"))),
             qn.quat_mul(H(f"{side}_ankle"), _wobble(frames, 20, (0, 1, 0), 0.7))),
        ]
    return joints


END_SITES = {"head": (0, 0, 0.12), "right_index2": (0, 0, -0.02), "left_index2": (0, 0, -0.02),
             "right_thumb": (0, 0, -0.03), "left_thumb": (0, 0, -0.03), "right_toe": (0.04, 0, 0), "left_toe": (0.04, 0, 0)}
SIX_CHANNELS = ("hips", "spine")
XYZ_JOINTS = ("left_thumb",)


def foreign_bvh_text(motion: ReferenceMotion, names: dict = MIXAMO_NAMES, frame: str = "z_up", body_scale: float = 1.1,
                     arm_out_deg: float = A_POSE_DEG, units_per_metre: float = 100.0) -> str:
    """The BVH text of `motion` on the foreign skeleton (centimetres unless told, `body_scale` times
    the humanoid; rest arms `arm_out_deg` out from hanging: 45 an A-pose, 90 a T-pose)."""
    link_pos, link_rot = forward_kinematics(motion.root_pos, motion.root_rot, motion.joint_rot)
    joints = _skeleton(link_rot, arm_out_deg)
    world = FRAMES[frame]
    q_world = world.as_quat(scalar_first=True)
    to_file = lambda q: qn.quat_mul(qn.quat_mul(q_world, q), qn.quat_conj(q_world))
    cm = units_per_metre * body_scale
    globals_ = {role: rot for role, _, _, rot in joints}
    columns, lines = [], ["HIERARCHY"]

    def emit(index: int, depth: int) -> None:
        role, parent, offset, rot = joints[index]
        pad = "  " * depth
        offset_file = cm * world.apply(offset)
        local = rot if parent is None else qn.quat_mul(qn.quat_conj(globals_[parent]), rot)
        order = "XYZ" if role in XYZ_JOINTS else "ZYX"
        channels = [f"{a}rotation" for a in order]
        if role in SIX_CHANNELS:
            channels = ["Xposition", "Yposition", "Zposition"] + channels
            position = cm * world.apply(link_pos[:, 0]) if parent is None else np.broadcast_to(offset_file, (len(rot), 3))
            columns.append(position)
        columns.append(Rotation.from_quat(to_file(local), scalar_first=True).as_euler(order, degrees=True))
        lines.append(f"{pad}{'ROOT' if parent is None else 'JOINT'} {names[role]}")
        lines.extend([f"{pad}{{", f"{pad}  OFFSET {' '.join(f'{v:.6f}' for v in offset_file)}",
                      f"{pad}  CHANNELS {len(channels)} {' '.join(channels)}"])
        for child in (i for i, j in enumerate(joints) if j[1] == role):
            emit(child, depth + 1)
        if role in END_SITES:
            end = cm * world.apply(np.asarray(END_SITES[role], np.float64))
            lines.extend([f"{pad}  End Site", f"{pad}  {{", f"{pad}    OFFSET {' '.join(f'{v:.6f}' for v in end)}", f"{pad}  }}"])
        lines.append(f"{pad}}}")

    emit(0, 0)
    frames = np.concatenate(columns, axis=1)
    lines += ["MOTION", f"Frames: {len(frames)}", f"Frame Time: {np.mean(np.diff(motion.frame_times)):.9f}"]
    lines += [" ".join(f"{v:.6f}" for v in row) for row in frames]
    return "\n".join(lines) + "\n"
