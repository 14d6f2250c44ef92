"""Reading and writing reference motions.

Formats
- DeepMimic motion files (JSON): `{"Loop": "wrap"|"none", "Frames": [[44 floats], ...]}`,
  each frame `duration, root pos (3), root quat (4, w first), then per joint a quaternion
  (spherical) or an angle (revolute)` in DeepMimic's order, Y up. Loaded into Z up, every
  quaternion normalised, the first frame's horizontal root position subtracted.
- The project's own `.npz` (format 1): `format` = "sfv-motion-1", `name`, `frame_times` (T,),
  `root_pos` (T, 3), `root_rot` (T, 4 wxyz), `joint_rot` (T, 12, 4 wxyz), `joint_names` (12,),
  `loop` (bool). Any other array is kept in `ReferenceMotion.extras` and written back.
  Optional arrays a video reconstruction adds (files without them load as before):
  `root_free` (bool; the camera moved, so the root path is not to be tracked, see
  `root_is_free`), `orientation_hint` / `orientation_hint_confidence` (T,), `camera_*`
  (T,), `video_start_frame`, `person_id`, and for a root-free motion with contacts
  `root_path` (T, 3) / `root_path_confidence` (T,), the path estimated from its contacts
  (`services/reconstruction/root_path.py`; read with `root_path_estimate`).
  For box scenes (`actors/envs/scene_reward.py`): `box_contacts` (T, 4) int, the box each of the
  feet and hands touches (-1 none); synthetic clips also carry `scene_truth` (`bench/scripts/box_clip.py`).
- BVH (`.bvh`, or any file starting with HIERARCHY) from any rig: the rig is detected from
  its joint names and the clip retargeted onto the humanoid (`actors/motion/formats/bvh_import.py`).
- Names: `deepmimic:<clip>` resolves to `pybullet_data/data/motions/humanoid3d_<clip>.txt`
  (install the `mocap` extra); `deepmimic:<clip>_mirror` is that clip mirrored left/right
  (`actors/character/mirror.py`), as is `FILE_mirror` for a motion file FILE; anything else is a path.

Every fault raises `MotionFormatError` with the file and the fault in one line.
"""
from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path

import numpy as np

from actors.character import quaternion as qn
from actors.character.mirror import MIRROR_SUFFIX, mirror_motion
from actors.motion.reference_motion import MotionFormatError, ReferenceMotion
from actors.character.skeleton import HINGE_AXIS, JOINT_IS_SPHERICAL, JOINT_NAMES, NUM_JOINTS, revolute_angle
from learner.atomic_io import atomic_output

DEEPMIMIC_COLUMNS = 1 + 3 + 4 + int(4 * JOINT_IS_SPHERICAL.sum() + (~JOINT_IS_SPHERICAL).sum())  # 44
NPZ_FORMAT = "sfv-motion-1"
MAX_DURATION_S = 1e5  # a day; longer "clips" are corrupt timing (and overflow when sampled)
DEEPMIMIC_CLIPS = (
    "backflip", "cartwheel", "crawl", "dance_a", "dance_b", "getup_facedown", "getup_faceup",
    "jump", "kick", "punch", "roll", "run", "spin", "spinkick", "walk",
)


def resolve_motion_path(name_or_path: str) -> Path:
    if name_or_path.startswith("deepmimic:"):
        clip = name_or_path.split(":", 1)[1]
        try:
            import pybullet_data
        except ImportError:
            raise MotionFormatError(f"{name_or_path}: needs the DeepMimic clips from pybullet_data (pip install 'sfv[mocap]')") from None
        path = Path(pybullet_data.getDataPath()) / "data" / "motions" / f"humanoid3d_{clip}.txt"
        if not path.is_file():
            raise MotionFormatError(f"{name_or_path}: no such DeepMimic clip (known: {', '.join(DEEPMIMIC_CLIPS)})")
        return path
    path = Path(name_or_path)
    if not path.is_file():
        raise MotionFormatError(f"{path}: motion file not found")
    return path


def _is_mirror_of_file(name: str) -> bool:
    """`FILE_mirror` where no such file exists but FILE does: FILE mirrored (how a mirrored
    expert names the clip of an expert trained on a file, `actors/character/mirror.mirrored_name`)."""
    return not Path(name).exists() and Path(name[: -len(MIRROR_SUFFIX)]).is_file()


def load_motion(name_or_path: str) -> ReferenceMotion:
    """Load a motion by name (`deepmimic:walk`, `deepmimic:walk_mirror`) or path (.npz,
    DeepMimic JSON or BVH)."""
    name = str(name_or_path)
    if name.endswith(MIRROR_SUFFIX) and (name.startswith("deepmimic:") or _is_mirror_of_file(name)):
        return mirror_motion(load_motion(name[: -len(MIRROR_SUFFIX)]))
    path = resolve_motion_path(name)
    try:
        with open(path, "rb") as f:
            magic = f.read(64)
    except OSError as exc:
        raise MotionFormatError(f"{path}: cannot read motion file ({exc.strerror or exc})") from None
    if _looks_like_bvh(path, magic):
        from actors.motion.formats.bvh_import import load_bvh_clip

        motion = load_bvh_clip(path)
        _check_derived(path, motion)
        motion.source = str(path)
        return motion
    # Overflow is detected after loading (`_check_derived`), so numpy need not warn about it.
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        motion = _load_npz(path) if magic.startswith(b"PK") else _load_deepmimic(path)
    _check_derived(path, motion)
    if str(name_or_path).startswith("deepmimic:"):
        motion.name = str(name_or_path)
    motion.source = str(path)
    return motion


def _looks_like_bvh(path: Path, head: bytes) -> bool:
    return path.suffix.lower() == ".bvh" or head.lstrip().startswith(b"HIERARCHY")


def is_bvh_file(path: str | os.PathLike) -> bool:
    """A .bvh name, or a file whose text starts with BVH's HIERARCHY keyword."""
    path = Path(path)
    try:
        with open(path, "rb") as f:
            return _looks_like_bvh(path, f.read(64))
    except OSError:
        return path.suffix.lower() == ".bvh"


# --------------------------------------------------------------------- validation
def _check_finite(path, what: str, array: np.ndarray):
    bad = ~np.isfinite(array)
    if bad.any():
        frame = int(np.argwhere(bad)[0][0])
        raise MotionFormatError(f"{path}: {what} holds NaN or infinite values (first at frame {frame})")


def _unit_quats(path, what: str, q: np.ndarray) -> np.ndarray:
    # Scale by the largest component first: the norm of huge components would overflow.
    largest = np.abs(q).max(axis=-1, keepdims=True)
    if (largest < 1e-6).any():
        frame = int(np.argwhere(largest[..., 0] < 1e-6)[0][0])
        raise MotionFormatError(f"{path}: {what} has a zero-length quaternion at frame {frame}")
    q = q / largest
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def _check_times(path, frame_times: np.ndarray):
    if len(frame_times) < 2:
        raise MotionFormatError(f"{path}: a motion needs at least 2 frames, found {len(frame_times)}")
    if not np.isfinite(frame_times).all():
        raise MotionFormatError(f"{path}: frame times overflow (durations too large)")
    steps = np.diff(frame_times)
    if (steps <= 0).any():
        frame = int(np.argmax(steps <= 0))
        raise MotionFormatError(f"{path}: frame times must increase (frame {frame + 1} is {steps[frame]:.6g} s after frame {frame})")


# ----------------------------------------------------------------------- DeepMimic
def _yup_quat_to_zup(q: np.ndarray) -> np.ndarray:
    return np.stack((q[..., 0], q[..., 1], -q[..., 3], q[..., 2]), axis=-1)


def _load_deepmimic(path: Path) -> ReferenceMotion:
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise MotionFormatError(f"{path}: not a motion file (neither .npz nor DeepMimic JSON: {exc.__class__.__name__})") from None
    if not isinstance(doc, dict) or "Frames" not in doc:
        raise MotionFormatError(f"{path}: DeepMimic JSON needs a 'Frames' list")
    frames = doc["Frames"]
    if not isinstance(frames, list) or not all(isinstance(row, list) for row in frames):
        raise MotionFormatError(f"{path}: 'Frames' must be a list of rows of numbers")
    widths = {len(row) for row in frames}
    if widths and widths != {DEEPMIMIC_COLUMNS}:
        bad = next(i for i, row in enumerate(frames) if len(row) != DEEPMIMIC_COLUMNS)
        raise MotionFormatError(f"{path}: frame {bad} has {len(frames[bad])} columns, expected {DEEPMIMIC_COLUMNS}")
    numbers = (int, float)
    if not all(isinstance(v, numbers) and not isinstance(v, bool) for row in frames for v in row):
        raise MotionFormatError(f"{path}: 'Frames' holds values that are not numbers")
    try:
        data = np.array(frames, dtype=np.float64).reshape(len(frames), DEEPMIMIC_COLUMNS)
    except OverflowError:
        raise MotionFormatError(f"{path}: 'Frames' holds a number too large for a float") from None
    _check_finite(path, "Frames", data)
    if len(data) < 2:
        raise MotionFormatError(f"{path}: a motion needs at least 2 frames, found {len(data)}")
    durations = data[:, 0]
    if (durations[:-1] <= 0).any():
        frame = int(np.argmax(durations[:-1] <= 0))
        raise MotionFormatError(f"{path}: frame durations must be positive (frame {frame} has {durations[frame]:.6g} s)")
    frame_times = np.concatenate(([0.0], np.cumsum(durations[:-1])))
    # A positive duration can still vanish next to a large time (1.0 + 1e-17 == 1.0).
    _check_times(path, frame_times)
    loop = str(doc.get("Loop", "none")).lower() == "wrap"

    root_pos = np.stack((data[:, 1], -data[:, 3], data[:, 2]), axis=-1)
    root_pos[:, :2] -= root_pos[0, :2]
    root_rot = _yup_quat_to_zup(_unit_quats(path, "root rotation", data[:, 4:8]))
    joint_rot = np.empty((len(data), NUM_JOINTS, 4))
    col = 8
    for j in range(NUM_JOINTS):
        if JOINT_IS_SPHERICAL[j]:
            joint_rot[:, j] = _yup_quat_to_zup(_unit_quats(path, f"{JOINT_NAMES[j]} rotation", data[:, col:col + 4]))
            col += 4
        else:
            joint_rot[:, j] = qn.quat_about_axis(data[:, col], HINGE_AXIS)
            col += 1
    return ReferenceMotion(path.stem, frame_times, root_pos, root_rot, joint_rot, loop)


# ---------------------------------------------------------------------------- npz
def _load_npz(path: Path) -> ReferenceMotion:
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except (zipfile.BadZipFile, ValueError, OSError, EOFError) as exc:
        raise MotionFormatError(f"{path}: unreadable .npz ({exc})") from None
    if str(arrays.get("format", "")) != NPZ_FORMAT:
        raise MotionFormatError(f"{path}: not an sfv motion file (format key must be '{NPZ_FORMAT}')")
    shapes = {"frame_times": (None,), "root_pos": (None, 3), "root_rot": (None, 4), "joint_rot": (None, NUM_JOINTS, 4)}
    for key, shape in shapes.items():
        if key not in arrays:
            raise MotionFormatError(f"{path}: missing array '{key}'")
        a = arrays[key]
        if a.ndim != len(shape) or any(s is not None and s != d for s, d in zip(shape, a.shape)):
            raise MotionFormatError(f"{path}: '{key}' has shape {a.shape}, expected {tuple('T' if s is None else s for s in shape)}")
        if not np.issubdtype(a.dtype, np.number):
            raise MotionFormatError(f"{path}: '{key}' is not numeric")
        _check_finite(path, key, a.astype(np.float64))
    t = arrays["frame_times"].astype(np.float64)
    if not (len(t) == len(arrays["root_pos"]) == len(arrays["root_rot"]) == len(arrays["joint_rot"])):
        raise MotionFormatError(f"{path}: frame_times, root_pos, root_rot and joint_rot differ in frame count")
    _check_times(path, t)
    names = tuple(str(n) for n in arrays.get("joint_names", JOINT_NAMES))
    if names != JOINT_NAMES:
        raise MotionFormatError(f"{path}: joint_names {names} do not match the humanoid's {JOINT_NAMES}")
    known = set(shapes) | {"format", "name", "loop", "joint_names"}
    extras = {k: v for k, v in arrays.items() if k not in known}
    _check_root_path(path, extras, len(t))
    return ReferenceMotion(
        str(arrays.get("name", path.stem)),
        t - t[0],
        arrays["root_pos"].astype(np.float64),
        _unit_quats(path, "root_rot", arrays["root_rot"].astype(np.float64)),
        _unit_quats(path, "joint_rot", arrays["joint_rot"].astype(np.float64)),
        bool(arrays.get("loop", False)),
        extras,
    )


def _check_root_path(path, extras: dict, frames: int) -> None:
    """The estimated root path, where present: (T, 3) and (T,) finite numbers."""
    for key, shape in (("root_path", (frames, 3)), ("root_path_confidence", (frames,))):
        if key not in extras:
            continue
        a = extras[key]
        if a.shape != shape or not np.issubdtype(a.dtype, np.number):
            raise MotionFormatError(f"{path}: '{key}' has shape {a.shape} ({a.dtype}), expected {shape} numbers")
        _check_finite(path, key, a.astype(np.float64))


def check_motion(path, motion: ReferenceMotion) -> None:
    """The checks every loaded motion passes (for loaders outside this module)."""
    _check_derived(path, motion)


def _check_derived(path, motion: ReferenceMotion) -> None:
    """Finite inputs can still give non-finite positions or velocities (1e308 apart, 1e-320 s)."""
    derived = {
        "frame times": motion.frame_times, "root positions": motion.root_pos,
        "root velocities": motion._root_lin_vel, "root angular velocities": motion._root_ang_vel,
        "joint angular velocities": motion._joint_ang_vel,
    }
    if motion.duration > MAX_DURATION_S:
        raise MotionFormatError(f"{path}: clip lasts {motion.duration:.3g} s; more than {MAX_DURATION_S:.0f} s is not a motion clip")
    for what, array in derived.items():
        if not np.isfinite(array).all():
            frame = int(np.argwhere(~np.isfinite(array))[0][0])
            raise MotionFormatError(f"{path}: {what} overflow at frame {frame} (values too large or frames too close in time)")


def save_motion(motion: ReferenceMotion, path: str | os.PathLike) -> Path:
    """Write the .npz atomically (temp file in the same folder, then rename)."""
    if motion.character != "humanoid3d":  # the format holds the humanoid's 12 joints
        raise MotionFormatError(f"{path}: a {motion.character} motion is a robot motion file (actors/motion/robot_motion.py)")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = dict(motion.extras)
    arrays.update(
        format=np.array(NPZ_FORMAT), name=np.array(motion.name), loop=np.array(motion.loop),
        frame_times=motion.frame_times, root_pos=motion.root_pos, root_rot=motion.root_rot,
        joint_rot=motion.joint_rot, joint_names=np.array(JOINT_NAMES),
    )
    with atomic_output(path) as tmp, open(tmp, "wb") as f:
        np.savez_compressed(f, **arrays)
    return path


def root_path_estimate(motion: ReferenceMotion) -> tuple[np.ndarray, np.ndarray] | None:
    """The estimated root path (T, 3) and its confidence (T,) of a root-free motion; None for
    motions without one (older files, mocap)."""
    if "root_path" not in motion.extras:
        return None
    path = np.asarray(motion.extras["root_path"], np.float64)
    confidence = motion.extras.get("root_path_confidence")
    return path, (np.ones(len(path)) if confidence is None else np.asarray(confidence, np.float64))


def root_is_free(motion: ReferenceMotion) -> bool:
    """True for motions whose root path is not to be tracked (reconstructed from a moving camera)."""
    return bool(np.asarray(motion.extras.get("root_free", False)))


def hinge_angles(motion: ReferenceMotion) -> np.ndarray:
    """(T, 4) revolute joint angles of a motion, for exporters."""
    return revolute_angle(motion.joint_rot[:, ~JOINT_IS_SPHERICAL])
