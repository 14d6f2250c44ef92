"""One description of the SFV / DeepMimic `humanoid3d` character.

Numbers are DeepMimic's (MIT, `data/characters/humanoid3d.txt` and
`data/controllers/humanoid3d_phase_rot_ctrl.txt`), written in its Y-up frame and converted
once here to MuJoCo's Z-up frame: p_zup = (x, -z, y). The character faces +x and its right
side is -y after the conversion.

Everything else (the MJCF in `humanoid.py`, forward kinematics in `kinematics.py`, the
DeepMimic motion loader) reads this module, so the model and its kinematics cannot drift.

Links are in DeepMimic order: root, chest, neck, right leg, right arm, left leg, left arm.
Wrists are welded (no joint) hand links. The 12 actuated joints are the non-root, non-wrist
links: 8 spherical (3-DoF) and 4 revolute (knees, elbows).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def yup_to_zup(v) -> np.ndarray:
    x, y, z = v
    return np.array([x, -z, y], dtype=np.float64)


@dataclass(frozen=True)
class Link:
    name: str
    parent: int
    joint: str  # "free" (root), "spherical", "revolute" or "fixed"
    offset_yup: tuple  # joint position in the parent link frame (DeepMimic, Y-up)
    limits: tuple  # per-axis (lo, hi) in radians, DeepMimic axes (x, y, z in Y-up)
    torque_limit: float
    kp: float
    kd: float
    end_effector: bool
    # Collision / mass geometry of the link (DeepMimic body def, Y-up attach point).
    shape: str
    mass: float
    geom_offset_yup: tuple
    # sphere: (radius,); capsule: (radius, cylinder length); box: full extents (x, y, z) Y-up.
    # DeepMimic's Param0 of spheres and capsules is a diameter: the radii here are half of it.
    size: tuple
    fall_contact: bool  # torso or head (the facts file's flag); the episode's fall rule is per clip: actors/envs/falls.py


LINKS: tuple[Link, ...] = (
    Link("root", -1, "free", (0, 0, 0), (), 0, 0, 0, False, "sphere", 6.0, (0, 0.07, 0), (0.09,), True),
    Link("chest", 0, "spherical", (0, 0.236151, 0), ((-1.2, 1.2),) * 3, 200, 1000, 100, False, "sphere", 14.0, (0, 0.12, 0), (0.11,), True),
    Link("neck", 1, "spherical", (0, 0.223894, 0), ((-1, 1),) * 3, 50, 100, 10, False, "sphere", 2.0, (0, 0.175, 0), (0.1025,), True),
    Link("right_hip", 0, "spherical", (0, 0, 0.084887), ((-1.2, 1.2), (-1, 1), (-1.57, 2.57)), 200, 500, 50, False, "capsule", 4.5, (0, -0.21, 0), (0.055, 0.3), False),
    Link("right_knee", 3, "revolute", (0, -0.421546, 0), ((-3.14, 0),), 150, 500, 50, False, "capsule", 3.0, (0, -0.2, 0), (0.05, 0.31), False),
    Link("right_ankle", 4, "spherical", (0, -0.40987, 0), ((-1, 1), (-1, 1), (-1.57, 1.57)), 90, 400, 40, True, "box", 1.0, (0.045, -0.0225, 0), (0.177, 0.055, 0.09), False),
    Link("right_shoulder", 1, "spherical", (-0.02405, 0.2435, 0.18311), ((-3.14, 0.5), (-1.5, 1.5), (-0.7, 3.14)), 100, 400, 40, False, "capsule", 1.5, (0, -0.14, 0), (0.045, 0.18), False),
    Link("right_elbow", 6, "revolute", (0, -0.274788, 0), ((0, 3.14),), 60, 300, 30, False, "capsule", 1.0, (0, -0.12, 0), (0.04, 0.135), False),
    Link("right_wrist", 7, "fixed", (0, -0.258947, 0), (), 0, 0, 0, True, "sphere", 0.5, (0, 0, 0), (0.04,), False),
    Link("left_hip", 0, "spherical", (0, 0, -0.084887), ((-1.2, 1.2), (-1, 1), (-1.57, 2.57)), 200, 500, 50, False, "capsule", 4.5, (0, -0.21, 0), (0.055, 0.3), False),
    Link("left_knee", 9, "revolute", (0, -0.421546, 0), ((-3.14, 0),), 150, 500, 50, False, "capsule", 3.0, (0, -0.2, 0), (0.05, 0.31), False),
    Link("left_ankle", 10, "spherical", (0, -0.40987, 0), ((-1, 1), (-1, 1), (-1.57, 1.57)), 90, 400, 40, True, "box", 1.0, (0.045, -0.0225, 0), (0.177, 0.055, 0.09), False),
    Link("left_shoulder", 1, "spherical", (-0.02405, 0.2435, -0.18311), ((-0.5, 3.14), (-1.5, 1.5), (-0.7, 3.14)), 100, 400, 40, False, "capsule", 1.5, (0, -0.14, 0), (0.045, 0.18), False),
    Link("left_elbow", 12, "revolute", (0, -0.274788, 0), ((0, 3.14),), 60, 300, 30, False, "capsule", 1.0, (0, -0.12, 0), (0.04, 0.135), False),
    Link("left_wrist", 13, "fixed", (0, -0.258947, 0), (), 0, 0, 0, True, "sphere", 0.5, (0, 0, 0), (0.04,), False),
)

LINK_NAMES: tuple[str, ...] = tuple(link.name for link in LINKS)
NUM_LINKS = len(LINKS)
PARENTS = np.array([link.parent for link in LINKS])
OFFSETS = np.stack([yup_to_zup(link.offset_yup) for link in LINKS])  # (15, 3), Z-up

# The 12 actuated joints, in DeepMimic's motion-file order.
JOINT_LINKS: tuple[int, ...] = tuple(i for i, link in enumerate(LINKS) if link.joint in ("spherical", "revolute"))
JOINT_NAMES: tuple[str, ...] = tuple(LINKS[i].name for i in JOINT_LINKS)
NUM_JOINTS = len(JOINT_LINKS)
JOINT_IS_SPHERICAL = np.array([LINKS[i].joint == "spherical" for i in JOINT_LINKS])
SPHERICAL_JOINTS = np.flatnonzero(JOINT_IS_SPHERICAL)
REVOLUTE_JOINTS = np.flatnonzero(~JOINT_IS_SPHERICAL)
# For each link, the index of its joint in JOINT_NAMES, or -1 (root, wrists).
LINK_JOINT = np.array([JOINT_LINKS.index(i) if i in JOINT_LINKS else -1 for i in range(NUM_LINKS)])

# DeepMimic's revolute joints turn about their local +z (Y-up); after the conversion that is -y.
HINGE_AXIS = yup_to_zup((0.0, 0.0, 1.0))

END_EFFECTOR_LINKS = np.array([i for i, link in enumerate(LINKS) if link.end_effector])  # ankles, wrists
FALL_CONTACT_LINKS = np.array([i for i, link in enumerate(LINKS) if link.fall_contact])  # root, chest, neck (torso and head)
TOTAL_MASS = float(sum(link.mass for link in LINKS))

# Degrees of freedom of the action and of MuJoCo's actuators.
NUM_ACTUATED_DOF = int(3 * JOINT_IS_SPHERICAL.sum() + (~JOINT_IS_SPHERICAL).sum())  # 28



def _partner_name(name: str) -> str:
    if name.startswith("right_"):
        return "left_" + name[len("right_"):]
    if name.startswith("left_"):
        return "right_" + name[len("left_"):]
    return name


# Left/right partners (the body is symmetric in the sagittal plane: actors/character/mirror.py).
LINK_MIRROR = np.array([LINK_NAMES.index(_partner_name(n)) for n in LINK_NAMES])  # link -> its partner
JOINT_MIRROR = np.array([JOINT_LINKS.index(LINK_MIRROR[i]) for i in JOINT_LINKS])  # JOINT_NAMES index -> partner's

# DeepMimic's humanoid3d `DiffWeight` per joint (the root's is 1, the welded wrists' 0): the
# imitation reward's joint weights (`actors/envs/modes/sfv/reward.py`).
DEEPMIMIC_JOINT_WEIGHTS = {"root": 1.0, "chest": 0.5, "neck": 0.3, "right_hip": 0.5, "right_knee": 0.3, "right_ankle": 0.2,
                           "right_shoulder": 0.3, "right_elbow": 0.2, "left_hip": 0.5, "left_knee": 0.3, "left_ankle": 0.2,
                           "left_shoulder": 0.3, "left_elbow": 0.2}


def joint_limits_zup(link: Link) -> np.ndarray:
    """Per-axis limits of a joint in the Z-up frame, shape (3, 2) or (1, 2).

    A Y-up axis permutation (x, y, z) -> (x, -z, y) also permutes the per-axis limits and
    flips the sign of the one that lands on -y.
    """
    if link.joint == "revolute":
        return np.array(link.limits, dtype=np.float64)  # same angle about HINGE_AXIS
    (xl, xh), (yl, yh), (zl, zh) = link.limits
    return np.array([(xl, xh), (-zh, -zl), (yl, yh)], dtype=np.float64)


def actuator_limits() -> np.ndarray:
    """(28, 2) per-actuator target limits (Z-up axes) in MuJoCo's actuator order: the ball
    joints' three axes first, then the hinges, each group in skeleton order."""
    spherical = [LINKS[i] for i in JOINT_LINKS if LINKS[i].joint == "spherical"]
    revolute = [LINKS[i] for i in JOINT_LINKS if LINKS[i].joint == "revolute"]
    return np.concatenate([joint_limits_zup(link) for link in spherical + revolute])


def revolute_angle(quat: np.ndarray) -> np.ndarray:
    """Signed angle about HINGE_AXIS of a quaternion that is (close to) such a rotation."""
    return 2.0 * np.arctan2(quat[..., 1:] @ HINGE_AXIS, quat[..., 0])
