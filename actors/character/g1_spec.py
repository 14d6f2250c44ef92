"""The numbers of the Unitree G1 (29 DoF, rev 1.0): joints, limits, actuators, key bodies.

The robot's geometry is Unitree's MJCF as shipped in the PyPI wheel `mjlab==1.6.0`
(Apache-2.0, `mjlab/asset_zoo/robots/unitree_g1/xmls/g1.xml`), fetched and cached by
`sfv models fetch --robot g1` (`actors/character/g1_model.py`); nothing of it is committed.
The joint order and ranges below are that file's (a test checks them against the cached XML).

The actuator figures are written here from the motor data in the same wheel's
`mjlab/asset_zoo/robots/unitree_g1/g1_constants.py` (Unitree's rotor inertias and two-stage
planetary gear ratios, effort limits; mjlab's choice of a 10 Hz natural frequency and a damping
ratio of 2 for the PD gains): the armature is the rotor inertia reflected through both gear
stages, kp = armature * w^2 and kd = 2 * zeta * armature * w. The waist pitch / roll and the
ankles are driven by two 5020 motors through a parallel linkage; like mjlab we take a nominal
1:1 linkage, i.e. twice one motor's armature, gains and effort.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

NAME = "g1"
MJLAB_REQUIREMENT = "mjlab==1.6.0"


@dataclass(frozen=True)
class Motor:
    """One motor type: rotor inertias of its three stages (kg m^2), gear ratios, effort (N m)."""

    name: str
    rotor_inertia: tuple[float, float, float]
    gears: tuple[float, float, float]  # the first stage is the rotor itself (1)
    effort_limit: float
    velocity_limit: float  # rad/s

    @property
    def armature(self) -> float:
        """Reflected inertia of a two-stage planetary gearbox at the output (kg m^2)."""
        (j1, j2, j3), (_, g2, g3) = self.rotor_inertia, self.gears
        return j1 * (g2 * g3) ** 2 + j2 * g3 ** 2 + j3


MOTORS = {
    "5020": Motor("5020", (0.139e-4, 0.017e-4, 0.169e-4), (1.0, 1.0 + 46.0 / 18.0, 1.0 + 56.0 / 16.0), 25.0, 37.0),
    "7520_14": Motor("7520_14", (0.489e-4, 0.098e-4, 0.533e-4), (1.0, 4.5, 1.0 + 48.0 / 22.0), 88.0, 32.0),
    "7520_22": Motor("7520_22", (0.489e-4, 0.109e-4, 0.738e-4), (1.0, 4.5, 5.0), 139.0, 20.0),
    "4010": Motor("4010", (0.068e-4, 0.0, 0.0), (1.0, 5.0, 5.0), 5.0, 22.0),
}
NATURAL_FREQUENCY = 10.0 * 2.0 * math.pi  # rad/s (mjlab's 10 Hz)
DAMPING_RATIO = 2.0

# name, qpos range (rad, g1.xml), motor, motors in parallel (linkage joints: 2)
_JOINTS: tuple[tuple[str, float, float, str, int], ...] = (
    ("left_hip_pitch_joint", -2.5307, 2.8798, "7520_14", 1),
    ("left_hip_roll_joint", -0.5236, 2.9671, "7520_22", 1),
    ("left_hip_yaw_joint", -2.7576, 2.7576, "7520_14", 1),
    ("left_knee_joint", -0.087267, 2.8798, "7520_22", 1),
    ("left_ankle_pitch_joint", -0.87267, 0.5236, "5020", 2),
    ("left_ankle_roll_joint", -0.2618, 0.2618, "5020", 2),
    ("right_hip_pitch_joint", -2.5307, 2.8798, "7520_14", 1),
    ("right_hip_roll_joint", -2.9671, 0.5236, "7520_22", 1),
    ("right_hip_yaw_joint", -2.7576, 2.7576, "7520_14", 1),
    ("right_knee_joint", -0.087267, 2.8798, "7520_22", 1),
    ("right_ankle_pitch_joint", -0.87267, 0.5236, "5020", 2),
    ("right_ankle_roll_joint", -0.2618, 0.2618, "5020", 2),
    ("waist_yaw_joint", -2.618, 2.618, "7520_14", 1),
    ("waist_roll_joint", -0.52, 0.52, "5020", 2),
    ("waist_pitch_joint", -0.52, 0.52, "5020", 2),
    ("left_shoulder_pitch_joint", -3.0892, 2.6704, "5020", 1),
    ("left_shoulder_roll_joint", -1.5882, 2.2515, "5020", 1),
    ("left_shoulder_yaw_joint", -2.618, 2.618, "5020", 1),
    ("left_elbow_joint", -1.0472, 2.0944, "5020", 1),
    ("left_wrist_roll_joint", -1.97222, 1.97222, "5020", 1),
    ("left_wrist_pitch_joint", -1.61443, 1.61443, "4010", 1),
    ("left_wrist_yaw_joint", -1.61443, 1.61443, "4010", 1),
    ("right_shoulder_pitch_joint", -3.0892, 2.6704, "5020", 1),
    ("right_shoulder_roll_joint", -2.2515, 1.5882, "5020", 1),
    ("right_shoulder_yaw_joint", -2.618, 2.618, "5020", 1),
    ("right_elbow_joint", -1.0472, 2.0944, "5020", 1),
    ("right_wrist_roll_joint", -1.97222, 1.97222, "5020", 1),
    ("right_wrist_pitch_joint", -1.61443, 1.61443, "4010", 1),
    ("right_wrist_yaw_joint", -1.61443, 1.61443, "4010", 1),
)

JOINT_NAMES: tuple[str, ...] = tuple(j[0] for j in _JOINTS)  # g1.xml's order = qpos[7:] order
NUM_JOINTS = len(JOINT_NAMES)  # 29, all hinges
JOINT_LIMITS = np.array([(lo, hi) for _, lo, hi, _, _ in _JOINTS])  # (29, 2) rad
_PARALLEL = np.array([j[4] for j in _JOINTS], dtype=np.float64)
ARMATURE = np.array([MOTORS[j[3]].armature for j in _JOINTS]) * _PARALLEL  # kg m^2
EFFORT_LIMITS = np.array([MOTORS[j[3]].effort_limit for j in _JOINTS]) * _PARALLEL  # N m
VELOCITY_LIMITS = np.array([MOTORS[j[3]].velocity_limit for j in _JOINTS])  # rad/s
KP = ARMATURE * NATURAL_FREQUENCY ** 2  # N m / rad
KD = 2.0 * DAMPING_RATIO * ARMATURE * NATURAL_FREQUENCY  # N m s / rad
# Residual actions (reference target + 0.5 rad x factor x action): at these soft gains 0.5 rad is
# 20 N m at a hip (kp 40) and 50 at a knee (kp 99), a quarter to a third of their motors' effort,
# where the humanoid3d's 0.5 rad reaches 1-2.5x its own (kp 300-1000, 50-200 N m). A run's stance
# knee alone needs more than 0.5 rad of lead. So each joint's range is effort / kp: the action's
# +-1 reaches the motor's effort limit at rest (mjlab sizes its G1 actions from the same ratio).
RESIDUAL_SCALE_FACTORS = EFFORT_LIMITS / KP / 0.5

# Each hinge's axis in its body frame, as g1.xml has it: pitch (knees, elbows) y, roll x, yaw z.
HINGE_AXES = np.array([(1.0, 0.0, 0.0) if "roll" in n else (0.0, 0.0, 1.0) if "yaw" in n else (0.0, 1.0, 0.0) for n in JOINT_NAMES])

NQ = 7 + NUM_JOINTS  # 36: free root (pos, quat wxyz), then the hinges
NV = 6 + NUM_JOINTS  # 35
JOINT_QPOS_ADR = 7 + np.arange(NUM_JOINTS)
JOINT_DOF_ADR = 6 + np.arange(NUM_JOINTS)

# Bodies of g1.xml in its (depth-first) order; body i + 1 in the compiled model.
LINK_NAMES: tuple[str, ...] = ("pelvis",) + tuple(
    [name.replace("_joint", "_link") for name in JOINT_NAMES[:12]]
    + ["waist_yaw_link", "waist_roll_link", "torso_link"]
    + [name.replace("_joint", "_link") for name in JOINT_NAMES[15:]])
ROOT_BODY = "pelvis"
TORSO_BODY = "torso_link"
FEET = ("left_ankle_roll_link", "right_ankle_roll_link")  # the links always allowed on the ground
HANDS = ("left_wrist_yaw_link", "right_wrist_yaw_link")
END_EFFECTORS = FEET + HANDS
FALL_CONTACT_GEOMS = ("pelvis_collision", "torso_collision", "head_collision")  # the torso and head

# The sole: the seven foot capsules of g1.xml (radius 0.01 at z = -0.025 in the ankle-roll
# frame) span x in [-0.054, 0.132] and y in [-0.026, 0.026]; their lowest points are these
# corners (ankle-roll frame, m).
SOLE_CORNERS = np.array([[x, y, -0.035] for x in (-0.054, 0.132) for y in (-0.026, 0.026)])

# A standing pose (mjlab's "knees bent" keyframe figures): root height and joint angles.
STANDING_ROOT_HEIGHT = 0.76
STANDING_POSE = {
    "hip_pitch_joint": -0.312, "knee_joint": 0.669, "ankle_pitch_joint": -0.363, "elbow_joint": 0.6,
    "left_shoulder_roll_joint": 0.2, "right_shoulder_roll_joint": -0.2, "shoulder_pitch_joint": 0.2,
}


def standing_joint_angles() -> np.ndarray:
    """(29,) the standing pose's joint angles."""
    angles = np.zeros(NUM_JOINTS)
    for i, name in enumerate(JOINT_NAMES):
        for key, value in STANDING_POSE.items():
            if name == key or (not key.startswith(("left_", "right_")) and name.endswith("_" + key)):
                angles[i] = value
    return angles


def _partner(name: str) -> str:
    if name.startswith("left_"):
        return "right_" + name[len("left_"):]
    if name.startswith("right_"):
        return "left_" + name[len("right_"):]
    return name


LINK_MIRROR = np.array([LINK_NAMES.index(_partner(n)) for n in LINK_NAMES])
JOINT_MIRROR = np.array([JOINT_NAMES.index(_partner(n)) for n in JOINT_NAMES])
# The G1 faces +x with its left at +y, so its sagittal plane is the world's x-z plane, and
# reflecting in it, S R(a, theta) S = R(-S a, theta), keeps the angle of a hinge whose partner's
# axis is -S a (pitch, knees, elbows: along y) and flips it where the axis is S a (roll and yaw:
# in the plane): a mirrored joint angle is sign * the partner's angle. This table is what the
# mirror maps read; `actors/character/symmetry.derive_hinge_mirror_signs` reads the same signs off
# the compiled model's world hinge axes at the zero pose (the shoulders' and hips' tilted axes
# included), and the mirror maps refuse to build where the two disagree.
JOINT_MIRROR_SIGN = np.array([1.0 if "pitch" in n or "knee" in n or "elbow" in n else -1.0 for n in JOINT_NAMES])

# The imitation reward's weights by link (the humanoid's DeepMimic weights spread over the
# hinges that stand for one of its joints; provisional until the G1 trains).
REWARD_JOINT_WEIGHTS: dict[str, float] = {"pelvis": 1.0}
for _name in LINK_NAMES[1:]:
    _part = _name.split("_", 1)[-1]
    REWARD_JOINT_WEIGHTS[_name] = (
        0.5 / 3 if _part.startswith("hip") else 0.3 if _part.startswith("knee") else 0.1 if _part.startswith("ankle")
        else 0.5 / 3 if _name.startswith("waist") or _name == "torso_link" else 0.1 if _part.startswith("shoulder")
        else 0.2 if _part.startswith("elbow") else 0.0)
