"""BVH (Biovision Hierarchy) writing and reading for the humanoid's motions.

Conventions of the files written here (what Blender, MotionBuilder and most BVH viewers expect):

- Y up, the character facing +x: DeepMimic's own frame, in which `actors/character/skeleton.py` writes
  its offsets. ReferenceMotion is Z up (p_zup = (x, -z, y)), so positions and rotations are
  turned back on the way out and on the way in.
- Lengths in centimetres by default (`units="cm"`), or metres (`units="m"`). BVH carries no
  unit field: import a centimetre file with scale 0.01 to get metres.
- The hierarchy is the skeleton's: ROOT `root`, then `chest`, `neck`, hips, knees, ankles,
  shoulders, elbows as JOINTs, each OFFSET its joint position in the parent link frame. The
  welded wrists become the elbows' End Site; the neck's End Site is the head centre and the
  ankles' the toe (front of the foot box).
- Every joint has three rotation channels `Zrotation Xrotation Yrotation` in degrees: the
  local rotation is Rz(a) Rx(b) Ry(c) (intrinsic z, x, y). Hinges (knees, elbows) turn about
  their local z, so they come out as (angle, 0, 0). The root first has
  `Xposition Yposition Zposition` (its world position).
- MOTION holds one frame per motion frame; `Frame Time` is the motion's frame period.
  Unevenly timed clips are resampled at their mean rate first.

The reader parses any BVH (any channel order, End Sites, CRLF); `bvh_to_motion` turns a
file with this skeleton back into a ReferenceMotion; files from other rigs are retargeted by
`actors/motion/formats/bvh_import.py` (`actors/motion/formats/retarget.py`).
"""
from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from actors.character import quaternion as qn
from actors.motion.reference_motion import ReferenceMotion
from actors.character.skeleton import JOINT_NAMES, LINKS, NUM_JOINTS
from learner.atomic_io import atomic_write_bytes
from learner.errors import SfvError

UNITS = {"cm": 100.0, "m": 1.0}
ROTATION_CHANNELS = ("Zrotation", "Xrotation", "Yrotation")
POSITION_CHANNELS = ("Xposition", "Yposition", "Zposition")
EULER_ORDER = "ZXY"  # scipy: upper case = intrinsic, matrix Rz @ Rx @ Ry


# ------------------------------------------------------------------------- frames
def zup_to_yup_vec(v: np.ndarray) -> np.ndarray:
    return np.stack((v[..., 0], v[..., 2], -v[..., 1]), axis=-1)


def yup_to_zup_vec(v: np.ndarray) -> np.ndarray:
    return np.stack((v[..., 0], -v[..., 2], v[..., 1]), axis=-1)


def zup_to_yup_quat(q: np.ndarray) -> np.ndarray:
    return np.stack((q[..., 0], q[..., 1], q[..., 3], -q[..., 2]), axis=-1)


def yup_to_zup_quat(q: np.ndarray) -> np.ndarray:
    return np.stack((q[..., 0], q[..., 1], -q[..., 3], q[..., 2]), axis=-1)


def quats_to_euler_deg(q: np.ndarray, order: str = EULER_ORDER) -> np.ndarray:
    """(..., 4) wxyz quaternions to (..., 3) intrinsic Euler angles in degrees, in `order`."""
    flat = q.reshape(-1, 4)
    with warnings.catch_warnings():
        # Near gimbal lock scipy sets the third angle to 0; the rotation itself is still exact.
        warnings.simplefilter("ignore", UserWarning)
        angles = Rotation.from_quat(flat, scalar_first=True).as_euler(order, degrees=True)
    return angles.reshape(q.shape[:-1] + (3,))


def euler_deg_to_quats(angles: np.ndarray, order: str = EULER_ORDER) -> np.ndarray:
    flat = angles.reshape(-1, 3)
    return Rotation.from_euler(order, flat, degrees=True).as_quat(scalar_first=True).reshape(angles.shape[:-1] + (4,))


# ---------------------------------------------------------------------- skeleton
@dataclass(frozen=True)
class BvhJoint:
    name: str
    parent: int  # index into the joint list, -1 for the root
    offset: np.ndarray  # (3,) in the parent frame, file units
    channels: tuple[str, ...]
    end_site: np.ndarray | None = None  # (3,) offset of the End Site, if the joint is a leaf


def end_site_yup(link_index: int) -> np.ndarray:
    """Where a leaf joint's End Site goes: a welded child link, else the tip of its geometry."""
    for child in LINKS:
        if child.parent == link_index and child.joint == "fixed":
            return np.asarray(child.offset_yup, np.float64)
    link = LINKS[link_index]
    tip = np.asarray(link.geom_offset_yup, np.float64).copy()
    if link.shape == "box":
        tip[0] += link.size[0] / 2.0  # the foot box's front: the toe
    return tip


def humanoid_bvh_joints(scale: float) -> list[BvhJoint]:
    """The humanoid's BVH hierarchy (depth first, the skeleton's child order), in file units."""
    keep = [i for i, link in enumerate(LINKS) if link.joint != "fixed"]
    joints: list[BvhJoint] = []

    def visit(link_index: int, parent: int) -> None:
        link = LINKS[link_index]
        children = [c for c in keep if LINKS[c].parent == link_index]
        channels = (POSITION_CHANNELS if parent < 0 else ()) + ROTATION_CHANNELS
        offset = np.zeros(3) if parent < 0 else scale * np.asarray(link.offset_yup, np.float64)
        end_site = None if children else scale * end_site_yup(link_index)
        joints.append(BvhJoint(link.name, parent, offset, channels, end_site))
        me = len(joints) - 1
        for child in children:
            visit(child, me)

    visit(0, -1)
    return joints


# ------------------------------------------------------------------------ writing
def _uniform_frames(motion: ReferenceMotion) -> tuple[np.ndarray, float]:
    """Frame times on an even grid (the motion's own if already even) and the period."""
    steps = np.diff(motion.frame_times)
    period = float(np.mean(steps))
    if np.ptp(steps) <= 1e-6 * period:
        return motion.frame_times, period
    count = int(round(motion.duration / period)) + 1
    return np.arange(count) * period, period


def motion_to_bvh_text(motion: ReferenceMotion, units: str = "cm") -> str:
    if units not in UNITS:
        raise SfvError(f"BVH units must be one of {', '.join(UNITS)}, got {units!r}")
    scale = UNITS[units]
    joints = humanoid_bvh_joints(scale)
    times, period = _uniform_frames(motion)
    if times is motion.frame_times:
        root_pos, root_rot, joint_rot = motion.root_pos, motion.root_rot, motion.joint_rot
    else:
        pose = motion.sample(times)
        root_pos, root_rot, joint_rot = pose.root_pos, pose.root_rot, pose.joint_rot
    columns = [scale * zup_to_yup_vec(root_pos), quats_to_euler_deg(zup_to_yup_quat(root_rot))]
    joint_euler = quats_to_euler_deg(zup_to_yup_quat(joint_rot))  # (T, 12, 3)
    for joint in joints[1:]:
        columns.append(joint_euler[:, JOINT_NAMES.index(joint.name)])
    frames = np.concatenate(columns, axis=1)

    lines = ["HIERARCHY"]
    _hierarchy_lines(joints, 0, 0, lines)
    lines += ["MOTION", f"Frames: {len(frames)}", f"Frame Time: {period:.9f}"]
    lines += [" ".join(f"{v:.6f}" for v in row) for row in frames]
    return "\n".join(lines) + "\n"


def _hierarchy_lines(joints: list[BvhJoint], index: int, depth: int, lines: list[str]) -> None:
    joint, pad = joints[index], "  " * depth
    fmt = lambda v: " ".join(f"{x:.6f}" for x in v)  # noqa: E731
    lines.append(f"{pad}{'ROOT' if joint.parent < 0 else 'JOINT'} {joint.name}")
    lines.append(f"{pad}{{")
    lines.append(f"{pad}  OFFSET {fmt(joint.offset)}")
    lines.append(f"{pad}  CHANNELS {len(joint.channels)} {' '.join(joint.channels)}")
    for child in (i for i, j in enumerate(joints) if j.parent == index):
        _hierarchy_lines(joints, child, depth + 1, lines)
    if joint.end_site is not None:
        lines += [f"{pad}  End Site", f"{pad}  {{", f"{pad}    OFFSET {fmt(joint.end_site)}", f"{pad}  }}"]
    lines.append(f"{pad}}}")


def write_bvh(motion: ReferenceMotion, path: str | os.PathLike, units: str = "cm") -> Path:
    """Write `motion` as BVH atomically (temp file in the same folder, then rename)."""
    return atomic_write_bytes(path, motion_to_bvh_text(motion, units).encode("ascii"))


# ------------------------------------------------------------------------ reading
@dataclass
class Bvh:
    joints: list[BvhJoint]
    frame_time: float
    frames: np.ndarray  # (T, total channels)
    channel_start: list[int] = field(default_factory=list)  # first column of each joint

    def joint_index(self, name: str) -> int:
        for index, joint in enumerate(self.joints):
            if joint.name == name:
                return index
        raise KeyError(name)

    def channels_of(self, index: int) -> np.ndarray:
        start = self.channel_start[index]
        return self.frames[:, start:start + len(self.joints[index].channels)]


class _Tokens:
    """Whitespace tokens with their line numbers, for errors that say where."""

    def __init__(self, path: Path, text: str):
        self.path = path
        self.items = [(tok, n) for n, line in enumerate(text.splitlines(), 1) for tok in line.split()]
        self.pos = 0

    def error(self, what: str) -> SfvError:
        line = self.items[min(self.pos, len(self.items) - 1)][1] if self.items else 1
        return SfvError(f"{self.path}: line {line}: {what}")

    def next(self, expected: str | None = None) -> str:
        if self.pos >= len(self.items):
            raise self.error(f"unexpected end of file (expected {expected or 'more'})")
        token = self.items[self.pos][0]
        if expected is not None and token != expected:
            raise self.error(f"expected '{expected}', found '{token}'")
        self.pos += 1
        return token

    def number(self, what: str) -> float:
        token = self.next()
        try:
            value = float(token)
        except ValueError:
            self.pos -= 1
            raise self.error(f"{what}: '{token}' is not a number") from None
        if not np.isfinite(value):
            self.pos -= 1
            raise self.error(f"{what} is not finite")
        return value


def _parse_joint(tokens: _Tokens, parent: int, joints: list[BvhJoint]) -> None:
    name = tokens.next()
    tokens.next("{")
    tokens.next("OFFSET")
    offset = np.array([tokens.number("OFFSET") for _ in range(3)])
    tokens.next("CHANNELS")
    count = tokens.number("channel count")
    if count != int(count) or not 0 <= count <= 6:
        raise tokens.error(f"joint {name}: channel count must be 0..6, got {count:g}")
    channels = tuple(tokens.next() for _ in range(int(count)))
    known = set(POSITION_CHANNELS) | {"Xrotation", "Yrotation", "Zrotation"}
    if not set(channels) <= known or len(set(channels)) != len(channels):
        raise tokens.error(f"joint {name}: bad channels {' '.join(channels)}")
    joints.append(BvhJoint(name, parent, offset, channels))
    me = len(joints) - 1
    while True:
        token = tokens.next()
        if token == "JOINT":
            _parse_joint(tokens, me, joints)
        elif token == "End":
            tokens.next("Site")
            tokens.next("{")
            tokens.next("OFFSET")
            end = np.array([tokens.number("End Site OFFSET") for _ in range(3)])
            tokens.next("}")
            joints[me] = BvhJoint(name, parent, offset, channels, end)
        elif token == "}":
            return
        else:
            tokens.pos -= 1
            raise tokens.error(f"expected JOINT, End Site or '}}' in joint {name}, found '{token}'")


def read_bvh(path: str | os.PathLike) -> Bvh:
    """Parse a BVH file; SfvError names the file and line of any fault."""
    path = Path(path)
    try:
        text = path.read_text(encoding="ascii", errors="strict")
    except FileNotFoundError:
        raise SfvError(f"{path}: BVH file not found") from None
    except (UnicodeDecodeError, OSError) as exc:
        raise SfvError(f"{path}: unreadable BVH ({type(exc).__name__})") from None
    tokens = _Tokens(path, text)
    tokens.next("HIERARCHY")
    tokens.next("ROOT")
    joints: list[BvhJoint] = []
    _parse_joint(tokens, -1, joints)
    tokens.next("MOTION")
    tokens.next("Frames:")
    count = tokens.number("Frames")
    if count != int(count) or count < 1:
        raise tokens.error(f"Frames must be a positive whole number, got {count:g}")
    tokens.next("Frame")
    tokens.next("Time:")
    frame_time = tokens.number("Frame Time")
    if frame_time <= 0:
        raise tokens.error(f"Frame Time must be positive, got {frame_time:g}")
    width = sum(len(j.channels) for j in joints)
    values = tokens.items[tokens.pos:]
    if len(values) != int(count) * width:
        raise SfvError(f"{path}: MOTION holds {len(values)} numbers, expected {int(count)} frames x {width} channels")
    try:
        frames = np.array([tok for tok, _ in values], dtype=np.float64).reshape(int(count), width)
    except ValueError:
        raise SfvError(f"{path}: MOTION holds values that are not numbers") from None
    if not np.isfinite(frames).all():
        frame = int(np.argwhere(~np.isfinite(frames))[0][0])
        raise SfvError(f"{path}: MOTION frame {frame} holds NaN or infinite values")
    starts = list(np.cumsum([0] + [len(j.channels) for j in joints[:-1]]))
    return Bvh(joints, frame_time, frames, [int(s) for s in starts])


# -------------------------------------------------------------------- to a motion
def rotation_quats(bvh: Bvh, index: int) -> np.ndarray:
    """(T, 4) wxyz local rotation of a joint from its rotation channels, whatever their order."""
    joint = bvh.joints[index]
    values = bvh.channels_of(index)
    picks = [k for k, c in enumerate(joint.channels) if c.endswith("rotation")]
    if not picks:
        return np.tile([1.0, 0.0, 0.0, 0.0], (len(bvh.frames), 1))
    order = "".join(joint.channels[k][0] for k in picks)  # e.g. "ZXY"
    angles = values[:, picks]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        rotation = Rotation.from_euler(order.upper(), angles, degrees=True)
    return rotation.as_quat(scalar_first=True)


def _continuous(q: np.ndarray) -> np.ndarray:
    """Flip signs so consecutive quaternions lie in the same hemisphere (slerp the short way)."""
    q = q.copy()
    flips = np.cumsum(np.sum(q[1:] * q[:-1], axis=-1) < 0, axis=0) % 2 == 1
    q[1:][flips] *= -1.0
    return q


def bvh_to_motion(bvh: Bvh, units: str = "cm", name: str = "bvh", path: str | os.PathLike = "BVH") -> ReferenceMotion:
    """A ReferenceMotion from a BVH file of this humanoid (joint names must match)."""
    if units not in UNITS:
        raise SfvError(f"BVH units must be one of {', '.join(UNITS)}, got {units!r}")
    names = {j.name for j in bvh.joints}
    missing = [n for n in ("root",) + JOINT_NAMES if n not in names]
    if missing:
        raise SfvError(f"{path}: not this humanoid's BVH (missing joints {', '.join(missing)})")
    root = bvh.joint_index("root")
    root_channels = bvh.joints[root].channels
    if not set(POSITION_CHANNELS) <= set(root_channels):
        raise SfvError(f"{path}: the root joint has no position channels")
    root_values = bvh.channels_of(root)
    root_pos_yup = np.stack([root_values[:, root_channels.index(c)] for c in POSITION_CHANNELS], axis=-1) / UNITS[units]
    root_rot = yup_to_zup_quat(rotation_quats(bvh, root))
    joint_rot = np.empty((len(bvh.frames), NUM_JOINTS, 4))
    for j, joint_name in enumerate(JOINT_NAMES):
        joint_rot[:, j] = yup_to_zup_quat(rotation_quats(bvh, bvh.joint_index(joint_name)))
    frame_times = np.arange(len(bvh.frames)) * bvh.frame_time
    return ReferenceMotion(
        name, frame_times, yup_to_zup_vec(root_pos_yup), qn.quat_normalize(_continuous(root_rot)),
        qn.quat_normalize(np.stack([_continuous(joint_rot[:, j]) for j in range(NUM_JOINTS)], axis=1)),
    )


def load_bvh_motion(path: str | os.PathLike, units: str = "cm") -> ReferenceMotion:
    return bvh_to_motion(read_bvh(path), units, Path(path).stem, path)
