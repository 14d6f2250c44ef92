"""A reference motion in the pose space of the character an env builds.

What an env imitates must be a pose of its own body: a humanoid clip (DeepMimic, BVH, a video
reconstruction: `formats/io.py`) for humanoid3d, a robot motion file (`robot_motion.py`, what
`sfv motion convert CLIP --character g1` writes) for a robot. `reference_for` takes either and
answers the character's `ReferenceMotion`: its own clip as it is, a robot file as the robot's
reference (`robot_reference.py`), and a humanoid clip for a robot retargeted onto it once, here,
by the retargeter registered for that robot (`RETARGETERS`; the G1's is `robot_retarget.py`),
said in one log line. `load_reference` reads a motion name or file for a character (`FILE_mirror`
of a robot motion file FILE: that motion mirrored, `robot_motion.mirror_robot_motion`).
A new robot registers its retargeter here beside its `Character` (`actors/character/characters.py`).
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path

from actors.motion.reference_motion import MotionFormatError, ReferenceMotion
from actors.character.mirror import MIRROR_SUFFIX
from actors.motion.robot_motion import RobotMotion, is_robot_motion, load_robot_motion, mirror_robot_motion
from actors.motion.robot_reference import robot_reference

log = logging.getLogger("sfv.motion")
HUMANOID = "humanoid3d"  # the pose space of every humanoid clip sfv reads


def _retarget_g1(motion: ReferenceMotion) -> tuple[RobotMotion, dict]:
    from actors.motion.robot_retarget import retarget_to_g1  # MuJoCo IK: only when a clip needs it

    return retarget_to_g1(motion)


# robot name -> retargeter of a humanoid clip: (robot motion, report with `key_body_error_m`)
RETARGETERS: dict[str, Callable[[ReferenceMotion], tuple[RobotMotion, dict]]] = {"g1": _retarget_g1}


def reference_for(motion: ReferenceMotion | RobotMotion, character) -> ReferenceMotion:
    """`motion` in `character`'s pose space (MotionFormatError in one line when it cannot be)."""
    if isinstance(motion, RobotMotion):
        return robot_reference(motion, character)
    if motion.character == character.name:
        return motion
    if motion.character != HUMANOID or character.name not in RETARGETERS:
        raise MotionFormatError(f"{motion.source or motion.name}: a {motion.character} motion cannot drive the {character.name}")
    robot, report = RETARGETERS[character.name](motion)
    log.warning("%s: a humanoid clip, retargeted onto the %s at load (%d frames in %.1f s, %s); "
                "`sfv motion convert %s --character %s --out FILE.npz` keeps the result",
                motion.name, character.name, robot.num_frames, report.get("seconds", 0.0), _error_text(report),
                motion.name, character.name)
    return robot_reference(robot, character)


def _error_text(report: dict) -> str:
    mean = report.get("key_body_error_m", {}).get("mean")
    return "see `sfv motion convert` for its report" if mean is None else f"mean key-body error {100 * mean:.1f} cm"


def load_reference(name_or_path: str, character) -> ReferenceMotion:
    """The reference of a motion name or file for `character`: a robot motion file as it is, any
    other motion through `formats/io.load_motion` (then retargeted when the body is a robot)."""
    from actors.motion.formats.io import load_motion

    if is_robot_motion(name_or_path):
        return reference_for(load_robot_motion(name_or_path, character.name), character)
    original = str(name_or_path).removesuffix(MIRROR_SUFFIX)
    if original != str(name_or_path) and not Path(name_or_path).exists() and is_robot_motion(original):
        # FILE_mirror of a robot motion file: the file mirrored (as `load_motion` does a humanoid clip's)
        return reference_for(mirror_robot_motion(load_robot_motion(original, character.name)), character)
    return reference_for(load_motion(name_or_path), character)
