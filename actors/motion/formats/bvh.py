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

The reader parses any BVH (any channel order, End Sites or none, CRLF, tabs, more or fewer
frames than declared: `read_bvh` lists what it tolerated); `bvh_to_motion` turns a
file with this skeleton back into a ReferenceMotion; files from other rigs are retargeted by
`actors/motion/formats/bvh_import.py` (`actors/motion/formats/retarget.py`).
"""
from __future__ import annotations

import os
import re
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
    return bvh_text(joints, np.concatenate(columns, axis=1), period)


def bvh_text(joints: list[BvhJoint], frames: np.ndarray, period: float) -> str:
    """The file: `joints` (depth first, the root first) and one line of `frames` (T, channels) per frame."""
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
CHANNEL_NAMES = {c.lower(): c for c in POSITION_CHANNELS + ("Xrotation", "Yrotation", "Zrotation")}
_FRAMES_LINE = re.compile(r"^\s*Frames\s*:\s*(.*?)\s*$", re.IGNORECASE)
_FRAME_TIME_LINE = re.compile(r"^\s*Frame\s*Time\s*:\s*(.*?)\s*$", re.IGNORECASE)
_CANONICAL_HEADER = (re.compile(r"^Frames: \S+$"), re.compile(r"^Frame Time: \S+$"))


@dataclass
class Bvh:
    joints: list[BvhJoint]
    frame_time: float
    frames: np.ndarray  # (T, total channels)
    channel_start: list[int] = field(default_factory=list)  # first column of each joint
    frames_declared: int | None = None  # the `Frames:` line (the file may hold more or fewer whole frames)
    quirks: dict = field(default_factory=dict)  # what the file does that exporters do and the reader tolerated

    def joint_index(self, name: str) -> int:
        for index, joint in enumerate(self.joints):
            if joint.name == name:
                return index
        raise KeyError(name)

    def channels_of(self, index: int) -> np.ndarray:
        start = self.channel_start[index]
        return self.frames[:, start:start + len(self.joints[index].channels)]

    def file_report(self) -> dict:
        """The file's frame counts and each tolerated quirk (`sfv motion convert` prints it)."""
        return {"frames_declared": self.frames_declared, "frames_read": int(len(self.frames)), "quirks": dict(self.quirks)}


class _Tokens:
    """Whitespace tokens with their line numbers, for errors that say where."""

    def __init__(self, path: Path, lines: list[str], first_line: int = 1):
        self.path = path
        self.items = [(tok, n) for n, line in enumerate(lines, first_line) for tok in line.split()]
        self.pos = 0

    def error(self, what: str) -> SfvError:
        line = self.items[min(self.pos, len(self.items) - 1)][1] if self.items else 1
        return SfvError(f"{self.path}: line {line}: {what}")

    def next(self, expected: str | None = None, ignore_case: bool = False) -> str:
        if self.pos >= len(self.items):
            raise self.error(f"unexpected end of file (expected {expected or 'more'})")
        token = self.items[self.pos][0]
        if expected is not None and token != expected and not (ignore_case and token.lower() == expected.lower()):
            raise self.error(f"expected '{expected}', found '{token}'")
        self.pos += 1
        return token

    def rest_of_line(self) -> list[str]:
        """The tokens after the last one read, up to the end of its line."""
        line = self.items[self.pos - 1][1]
        out = []
        while self.pos < len(self.items) and self.items[self.pos][1] == line:
            out.append(self.items[self.pos][0])
            self.pos += 1
        return out

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


def _note(quirks: dict, key: str, item: str) -> None:
    quirks.setdefault(key, [])
    if item not in quirks[key]:
        quirks[key].append(item)


def _parse_joint(tokens: _Tokens, parent: int, joints: list[BvhJoint], quirks: dict) -> None:
    words = tokens.rest_of_line()  # the name is the rest of the line: exporters write `JOINT Left Hip`
    opened = bool(words) and words[-1] == "{"
    if opened:
        words = words[:-1]
    if not words:
        raise tokens.error("a joint without a name")
    name = " ".join(words)
    if len(words) > 1:
        _note(quirks, "joint_names_with_spaces", name)
    if not opened:
        tokens.next("{")
    tokens.next("OFFSET")
    offset = np.array([tokens.number("OFFSET") for _ in range(3)])
    tokens.next("CHANNELS")
    count = tokens.number("channel count")
    if count != int(count) or not 0 <= count <= 6:
        raise tokens.error(f"joint {name}: channel count must be 0..6, got {count:g}")
    listed = tokens.rest_of_line()
    if len(listed) != int(count):
        raise tokens.error(f"joint {name}: CHANNELS says {int(count)} but lists {len(listed)} ({' '.join(listed)})")
    channels = tuple(CHANNEL_NAMES.get(c.lower(), c) for c in listed)
    if not set(channels) <= set(CHANNEL_NAMES.values()) or len(set(channels)) != len(channels):
        raise tokens.error(f"joint {name}: bad channels {' '.join(listed)}")
    if channels != tuple(listed):
        _note(quirks, "channel_names_in_other_case", name)
    joints.append(BvhJoint(name, parent, offset, channels))
    me, children = len(joints) - 1, 0
    while True:
        token = tokens.next()
        if token == "JOINT":
            _parse_joint(tokens, me, joints, quirks)
            children += 1
        elif token.lower() == "end":
            tokens.next("Site", ignore_case=True)
            tokens.next("{")
            tokens.next("OFFSET")
            end = np.array([tokens.number("End Site OFFSET") for _ in range(3)])
            tokens.next("}")
            joints[me] = BvhJoint(name, parent, offset, channels, end)
        elif token == "}":
            if children == 0 and joints[me].end_site is None:
                _note(quirks, "leaf_joints_without_end_site", name)
            return
        else:
            tokens.pos -= 1
            raise tokens.error(f"expected JOINT, End Site or '}}' in joint {name}, found '{token}'")


def _header_value(path: Path, lines: list[str], index: int, pattern: re.Pattern, what: str) -> tuple[str, int]:
    """The value of the MOTION header line `what` at or after `index` (blank lines skipped)."""
    while index < len(lines) and not lines[index].strip():
        index += 1
    if index >= len(lines):
        raise SfvError(f"{path}: line {index}: unexpected end of file (expected '{what}:')")
    match = pattern.match(lines[index])
    if match is None:
        raise SfvError(f"{path}: line {index + 1}: expected '{what}:', found '{lines[index].strip()[:40]}'")
    return match.group(1), index


def _header_number(path: Path, text: str, index: int, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise SfvError(f"{path}: line {index + 1}: {what}: '{text}' is not a number") from None
    if not np.isfinite(value):
        raise SfvError(f"{path}: line {index + 1}: {what} is not finite")
    return value


def read_bvh(path: str | os.PathLike) -> Bvh:
    """Parse a BVH file as exporters write them; SfvError names the file and line of any fault.

    Tolerated (and listed in `Bvh.quirks`): more or fewer whole frames than `Frames:` declares
    (what is there is read), CRLF or CR line ends, tabs, blank lines, a UTF-8 byte-order mark,
    `Frames:` / `Frame Time:` spacing, joint names with spaces (colons need nothing), leaf
    joints without an End Site, channel names in another case. Errors: a partial frame (a
    line with fewer or more values than the hierarchy's channels), a value that is not a
    number, a CHANNELS line whose count is not the number of channels it lists.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise SfvError(f"{path}: BVH file not found") from None
    except OSError as exc:
        raise SfvError(f"{path}: unreadable BVH ({type(exc).__name__})") from None
    quirks: dict = {}
    if raw.startswith(b"\xef\xbb\xbf"):
        quirks["utf8_byte_order_mark"] = True
        raw = raw[3:]
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise SfvError(f"{path}: unreadable BVH (not text: UnicodeDecodeError)") from None
    if "\r\n" in text:
        quirks["crlf_line_ends"] = True
    elif "\r" in text:
        quirks["cr_line_ends"] = True
    if "\t" in text:
        quirks["tabs"] = True
    lines = text.splitlines()
    motion_at = next((i for i, line in enumerate(lines) if line.strip().upper() == "MOTION"), len(lines))
    tokens = _Tokens(path, lines[:motion_at])
    tokens.next("HIERARCHY")
    tokens.next("ROOT")
    joints: list[BvhJoint] = []
    _parse_joint(tokens, -1, joints, quirks)
    if tokens.pos < len(tokens.items):
        raise tokens.error(f"expected MOTION after the hierarchy, found '{tokens.items[tokens.pos][0]}'")
    if motion_at == len(lines):
        raise tokens.error("unexpected end of file (expected MOTION)")
    count_text, index = _header_value(path, lines, motion_at + 1, _FRAMES_LINE, "Frames")
    declared = _header_number(path, count_text, index, "Frames")
    if declared != int(declared) or declared < 0:
        raise SfvError(f"{path}: line {index + 1}: Frames must be a whole number, got {declared:g}")
    headers = [lines[index].strip()]
    time_text, index = _header_value(path, lines, index + 1, _FRAME_TIME_LINE, "Frame Time")
    frame_time = _header_number(path, time_text, index, "Frame Time")
    if frame_time <= 0:
        raise SfvError(f"{path}: line {index + 1}: Frame Time must be positive, got {frame_time:g}")
    headers.append(lines[index].strip())
    if not all(pattern.match(line) for pattern, line in zip(_CANONICAL_HEADER, headers)):
        quirks["motion_header_spacing"] = headers  # e.g. `Frame Time:0.0333` or `Frames :  76`
    width = sum(len(j.channels) for j in joints)
    rows, blank = [], 0
    for number, line in enumerate(lines[index + 1:], index + 2):
        values = line.split()
        if not values:
            blank += 1
            continue
        if len(values) != width:
            raise SfvError(f"{path}: line {number}: MOTION frame {len(rows)} holds {len(values)} values, expected {width} "
                           f"(the hierarchy's channels): a partial frame")
        try:
            rows.append([float(v) for v in values])
        except ValueError:
            bad = next(v for v in values if not _is_number(v))
            raise SfvError(f"{path}: line {number}: MOTION frame {len(rows)}: '{bad}' is not a number") from None
    blank += sum(1 for line in lines[:motion_at] if not line.strip())
    if blank:
        quirks["blank_lines"] = blank
    if not rows:
        raise SfvError(f"{path}: MOTION holds no frames (Frames: {int(declared)})")
    frames = np.array(rows, dtype=np.float64).reshape(len(rows), width)
    if len(rows) != int(declared):
        quirks["frame_count"] = f"Frames: {int(declared)} declared, {len(rows)} whole frames read"
    if not np.isfinite(frames).all():
        frame = int(np.argwhere(~np.isfinite(frames))[0][0])
        raise SfvError(f"{path}: MOTION frame {frame} holds NaN or infinite values")
    starts = list(np.cumsum([0] + [len(j.channels) for j in joints[:-1]]))
    return Bvh(joints, frame_time, frames, [int(s) for s in starts], int(declared), quirks)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


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
