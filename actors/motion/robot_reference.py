"""A robot motion file as the env's reference: a `ReferenceMotion` in the robot's pose space.

A robot motion (`robot_motion.py`: root pose and hinge angles per frame) becomes a
`ReferenceMotion` whose `joint_rot` holds each hinge as the rotation about its axis
(`Character.hinge_axes`) and whose `character` is the robot's. The reference track then samples
it as it samples a humanoid clip: root and joints slerped between frames (about a fixed axis a
slerp is the linear blend of the angles), velocities the central differences of the frames (a
hinge's is its angle rate along the axis), and `StateLayout.pose_to_qpos_qvel` reads the angles
back about the same axes. Nothing in the track, the state layout or the reward knows a robot.
"""
from __future__ import annotations

import numpy as np

from actors.character import quaternion as qn
from actors.motion.reference_motion import MotionFormatError, ReferenceMotion
from actors.motion.robot_motion import RobotMotion, clip_to_limits


def robot_reference(motion: RobotMotion, character) -> ReferenceMotion:
    """`motion` (a robot motion of `character`, its joints in the character's order) as a reference."""
    if motion.character != character.name or tuple(motion.joint_names) != tuple(character.joint_names):
        raise MotionFormatError(f"{motion.source or motion.name}: a motion of the {motion.character}'s "
                                f"{len(motion.joint_names)} joints, not of the {character.name}'s")
    if character.joint_is_spherical.any():
        raise MotionFormatError(f"{motion.name}: robot motions hold hinge angles; the {character.name} has ball joints")
    half = 0.5 * np.asarray(motion.joint_pos, np.float64)[..., None]  # (T, J, 1)
    joint_rot = np.concatenate((np.cos(half), np.sin(half) * np.asarray(character.hinge_axes, np.float64)), axis=-1)
    times = np.arange(motion.num_frames) / motion.fps
    return ReferenceMotion(motion.name, times, np.asarray(motion.root_pos, np.float64), qn.quat_normalize(motion.root_quat),
                           joint_rot, loop=motion.loop, source=motion.source, character=character.name)


def robot_motion_of(reference: ReferenceMotion, character, source: str = "") -> RobotMotion:
    """The inverse: a reference in `character`'s pose space (a recorded rollout) as a robot motion
    file's contents. Frames must be evenly spaced (the file has one fps)."""
    if reference.character != character.name:
        raise MotionFormatError(f"{reference.name}: a {reference.character} motion, not the {character.name}'s")
    steps = np.diff(reference.frame_times)
    if not np.allclose(steps, steps[0], rtol=1e-6):
        raise MotionFormatError(f"{reference.name}: a robot motion file needs evenly spaced frames")
    axes = np.asarray(character.hinge_axes, np.float64)
    # The signed angle about each hinge's axis (as StateLayout reads a hinge's quaternion).
    angles = 2.0 * np.arctan2(np.einsum("tjk,jk->tj", reference.joint_rot[..., 1:], axes), reference.joint_rot[..., 0])
    motion = RobotMotion(character.name, reference.name, source or reference.source or reference.name, float(1.0 / steps[0]),
                         reference.loop, tuple(character.joint_names), reference.root_pos.copy(), reference.root_rot.copy(), angles)
    return clip_to_limits(motion, np.asarray(character.actuator_limits, np.float64), reference.name)  # every joint a hinge: its limits; soft passed in simulation
