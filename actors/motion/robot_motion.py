"""A reference motion for a robot with hinge joints (the Unitree G1): the file and its loader.

Format `sfv-robot-motion-1` (.npz, written atomically):

| key | shape | what |
|---|---|---|
| `format` | () str | "sfv-robot-motion-1" |
| `character` | () str | the robot ("g1") |
| `name` | () str | the clip's name |
| `source` | () str | what it was retargeted from (`deepmimic:walk`, a file path) |
| `fps` | () float | frames per second (frames evenly spaced from t = 0) |
| `loop` | () bool | the clip is cyclic |
| `joint_names` | (J,) str | the hinge joints, in the robot's qpos order |
| `root_pos` | (T, 3) | the root body's (pelvis) world position, metres, Z up |
| `root_quat` | (T, 4) | its world orientation, unit quaternion (w, x, y, z) |
| `joint_pos` | (T, J) | joint angles (rad), within the robot's limits |
| `contacts` | (T, 2) bool | optional: left, right foot on the ground (from the source) |

`qpos` of frame t is `root_pos[t], root_quat[t], joint_pos[t]` (MuJoCo's free joint, then the
hinges). Every fault is a `MotionFormatError` naming the file and the fault in one line.
"""
from __future__ import annotations

import dataclasses
import logging
import os
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from actors.motion.reference_motion import MotionFormatError
from learner.atomic_io import atomic_output

log = logging.getLogger("sfv.motion")
# MuJoCo's joint limits are soft constraints: a simulated joint under load passes its limit by
# up to a few hundredths of a radian (a G1 rollout: waist roll 0.538 against 0.520). A file
# that far out is read with its angles clipped and the overshoot reported; farther is an error.
LIMIT_TOLERANCE_RAD = 0.05

FORMAT = "sfv-robot-motion-1"


@dataclass
class RobotMotion:
    character: str
    name: str
    source: str
    fps: float
    loop: bool
    joint_names: tuple[str, ...]
    root_pos: np.ndarray  # (T, 3)
    root_quat: np.ndarray  # (T, 4) wxyz
    joint_pos: np.ndarray  # (T, J)
    contacts: np.ndarray | None = None  # (T, 2) bool: left, right

    @property
    def num_frames(self) -> int:
        return len(self.root_pos)

    @property
    def duration(self) -> float:
        return (self.num_frames - 1) / self.fps

    def qpos(self) -> np.ndarray:
        """(T, 7 + J) MuJoCo qpos per frame."""
        return np.concatenate((self.root_pos, self.root_quat, self.joint_pos), axis=1)

    def summary(self) -> dict:
        return {"name": self.name, "character": self.character, "source": self.source, "frames": self.num_frames,
                "duration": round(self.duration, 6), "fps": round(self.fps, 6), "loop": self.loop,
                "joints": len(self.joint_names)}


def _fail(path, fault: str) -> MotionFormatError:
    return MotionFormatError(f"{path}: {fault}")


def validate(motion: RobotMotion, path="robot motion", joint_names: tuple[str, ...] | None = None,
             limits: np.ndarray | None = None) -> None:
    """Shapes, finiteness, unit quaternions, and (when given) the robot's joints and limits."""
    frames, joints = motion.num_frames, len(motion.joint_names)
    if frames < 2:
        raise _fail(path, f"{frames} frame(s); a motion needs at least 2")
    if not (np.isfinite(motion.fps) and motion.fps > 0):
        raise _fail(path, f"fps {motion.fps} is not a positive number")
    for key, value, shape in (("root_pos", motion.root_pos, (frames, 3)), ("root_quat", motion.root_quat, (frames, 4)),
                              ("joint_pos", motion.joint_pos, (frames, joints))):
        if value.shape != shape:
            raise _fail(path, f"{key} has shape {value.shape}, expected {shape}")
        if not np.all(np.isfinite(value)):
            raise _fail(path, f"{key} holds NaN or infinite values")
    norms = np.linalg.norm(motion.root_quat, axis=1)
    if np.max(np.abs(norms - 1.0)) > 1e-3:
        bad = int(np.argmax(np.abs(norms - 1.0)))
        raise _fail(path, f"root_quat of frame {bad} has norm {norms[bad]:.4f}, not 1")
    if motion.contacts is not None and motion.contacts.shape != (frames, 2):
        raise _fail(path, f"contacts has shape {motion.contacts.shape}, expected {(frames, 2)}")
    if joint_names is not None and tuple(motion.joint_names) != tuple(joint_names):
        raise _fail(path, f"joint_names are not the {motion.character}'s {len(joint_names)} joints in order")
    if limits is not None:
        slack = 1e-6
        over = (motion.joint_pos < limits[:, 0] - slack) | (motion.joint_pos > limits[:, 1] + slack)
        if over.any():
            frame, joint = map(int, np.argwhere(over)[0])
            raise _fail(path, f"joint {motion.joint_names[joint]} at frame {frame} is {motion.joint_pos[frame, joint]:.4f} rad, "
                              f"outside its limits [{limits[joint, 0]:.4f}, {limits[joint, 1]:.4f}]")


def mirror_robot_motion(motion: RobotMotion, character=None) -> RobotMotion:
    """The motion reflected in the robot's sagittal plane (the world's x-z plane), left and right
    swapped (`actors/character/mirror.py`): root position (x, -y, z), root orientation S R S
    (quaternion (w, -x, y, -z)), each hinge its partner's angle times the joint's mirror sign
    (`joint_mirror_sign`), the feet's contacts swapped; named `<name>_mirror` (and back; a
    retargeted clip's `<clip>_g1` becomes `<clip>_mirror_g1`, `mirror.mirrored_name`), its source
    likewise. `character` defaults to the registered body the motion names. Mirroring
    twice is the original, exactly."""
    from actors.character.mirror import POLAR, QUAT, mirror_signs, mirrored_name

    if character is None:
        from actors.character.characters import character_named

        character = character_named(motion.character)
    if motion.character != character.name or tuple(motion.joint_names) != tuple(character.joint_names):
        raise MotionFormatError(f"{motion.source or motion.name}: a motion of the {motion.character}'s "
                                f"{len(motion.joint_names)} joints, not of the {character.name}'s")
    signs, partner = mirror_signs(character), np.asarray(character.joint_mirror)
    name, source = mirrored_name(motion.name, motion.character), motion.source
    return RobotMotion(motion.character, name, mirrored_name(source, motion.character) if source else source,
                       motion.fps, motion.loop, tuple(motion.joint_names), np.asarray(motion.root_pos) * POLAR,
                       np.asarray(motion.root_quat) * QUAT, np.asarray(motion.joint_pos)[:, partner] * signs,
                       None if motion.contacts is None else np.asarray(motion.contacts)[:, ::-1].copy())


def save_robot_motion(motion: RobotMotion, path: str | os.PathLike) -> Path:
    validate(motion)
    path = Path(path)
    arrays = dict(format=np.array(FORMAT), character=np.array(motion.character), name=np.array(motion.name),
                  source=np.array(motion.source), fps=np.array(float(motion.fps)), loop=np.array(bool(motion.loop)),
                  joint_names=np.array(motion.joint_names), root_pos=motion.root_pos, root_quat=motion.root_quat,
                  joint_pos=motion.joint_pos)
    if motion.contacts is not None:
        arrays["contacts"] = np.asarray(motion.contacts, dtype=bool)
    with atomic_output(path) as tmp, open(tmp, "wb") as handle:
        np.savez_compressed(handle, **arrays)
    return path


def _scalar(data, key: str, path, kind):
    if key not in data:
        raise _fail(path, f"missing '{key}'")
    value = data[key]
    if value.shape != ():
        raise _fail(path, f"'{key}' should be a single value, has shape {value.shape}")
    try:
        return kind(value.item())
    except (TypeError, ValueError):
        raise _fail(path, f"'{key}' is not a {kind.__name__}") from None


def load_robot_motion(path: str | os.PathLike, character: str | None = None) -> RobotMotion:
    """Read and validate a robot motion file (against the robot's joints and limits for the G1)."""
    path = Path(path)
    if not path.is_file():
        raise _fail(path, "no such file")
    try:
        with np.load(path, allow_pickle=False) as data:
            fmt = _scalar(data, "format", path, str)
            if fmt != FORMAT:
                raise _fail(path, f"format '{fmt}' is not {FORMAT} (a humanoid motion? robot motions come from "
                                  "`sfv motion convert CLIP --character g1`)")
            for key in ("joint_names", "root_pos", "root_quat", "joint_pos"):
                if key not in data:
                    raise _fail(path, f"missing '{key}'")
            motion = RobotMotion(
                character=_scalar(data, "character", path, str), name=_scalar(data, "name", path, str),
                source=_scalar(data, "source", path, str), fps=_scalar(data, "fps", path, float),
                loop=_scalar(data, "loop", path, bool), joint_names=tuple(str(n) for n in data["joint_names"]),
                root_pos=np.asarray(data["root_pos"], np.float64), root_quat=np.asarray(data["root_quat"], np.float64),
                joint_pos=np.asarray(data["joint_pos"], np.float64),
                contacts=np.asarray(data["contacts"], bool) if "contacts" in data else None)
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        if isinstance(exc, MotionFormatError):
            raise
        raise _fail(path, f"not a readable .npz ({exc})") from None
    if character is not None and motion.character != character:
        raise _fail(path, f"a motion for '{motion.character}', not for '{character}'")
    joint_names = limits = None
    if motion.character == "g1":
        from actors.character import g1_spec

        joint_names, limits = g1_spec.JOINT_NAMES, g1_spec.JOINT_LIMITS
        motion = clip_to_limits(motion, limits, path)
    validate(motion, path, joint_names, limits)
    return motion


def clip_to_limits(motion: RobotMotion, limits: np.ndarray, path="robot motion",
                   tolerance: float = LIMIT_TOLERANCE_RAD) -> RobotMotion:
    """The motion with joint angles at most `tolerance` past their limits clipped onto them (a
    one-line warning naming the worst); angles farther out are left for `validate` to refuse."""
    if motion.joint_pos.shape[1:] != (len(limits),):
        return motion  # validate names the shape
    below, above = limits[:, 0] - motion.joint_pos, motion.joint_pos - limits[:, 1]
    over = np.maximum(below, above)
    if not (over > 1e-6).any() or over.max() > tolerance:
        return motion
    frame, joint = np.unravel_index(int(np.argmax(over)), over.shape)
    log.warning("%s: %d joint angle(s) past their limits by up to %.3f rad (%s at frame %d, as a simulator's soft "
                "limits allow), clipped onto them", path, int((over > 1e-6).sum()), float(over.max()),
                motion.joint_names[joint], int(frame))
    return dataclasses.replace(motion, joint_pos=np.clip(motion.joint_pos, limits[:, 0], limits[:, 1]))


def is_robot_motion(path: str | os.PathLike) -> bool:
    """True for an .npz whose `format` is a robot motion's (anything unreadable: False)."""
    path = Path(path)
    if path.suffix.lower() != ".npz" or not path.is_file():
        return False
    try:
        with np.load(path, allow_pickle=False) as data:
            return "format" in data.files and str(data["format"]) == FORMAT
    except (OSError, ValueError, zipfile.BadZipFile, EOFError):
        return False
