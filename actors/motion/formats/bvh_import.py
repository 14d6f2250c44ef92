"""A BVH file from any rig as a ReferenceMotion: parse, pick the rig, retarget.

`sfv motion convert CLIP.bvh`, `sfv train --motion CLIP.bvh` and every other `load_motion`
caller come through here. The project's own export (the `sfv` rig with the humanoid's own
offsets, in cm or m) is read back exactly by `bvh.bvh_to_motion`; every other rig goes
through `retarget.retarget`.
"""
from __future__ import annotations

import logging
import os
from pathlib import Path

import numpy as np

from actors.motion.formats.bvh import UNITS, Bvh, bvh_to_motion, humanoid_bvh_joints, read_bvh
from actors.motion.reference_motion import MotionFormatError, ReferenceMotion
from actors.motion.formats.retarget import RetargetOptions, is_loop, retarget
from actors.motion.formats.rigs import resolve_rig
from learner.errors import SfvError

FILE_REPORT = "file"  # the report's key for the file's frame counts and tolerated quirks (`Bvh.file_report`)
log = logging.getLogger("sfv.bvh")
_warned: set[str] = set()


def own_export_units(bvh: Bvh) -> str | None:
    """'cm' or 'm' when the file is this humanoid's own skeleton (names and offsets), else None."""
    theirs = {j.name: j.offset for j in bvh.joints}
    for units, scale in UNITS.items():
        ours = humanoid_bvh_joints(scale)
        if all(j.name in theirs and np.allclose(theirs[j.name], j.offset, atol=1e-4 * scale) for j in ours):
            return units
    return None


def import_bvh(path: str | os.PathLike, rig: str = "auto", options: RetargetOptions | None = None) -> tuple[ReferenceMotion, dict]:
    """(motion, report): the retargeting's report with the file's frame counts and the quirks the
    reader tolerated under `file`. Any fault is one SfvError line naming the file."""
    options = options or RetargetOptions()
    path = Path(path)
    try:
        bvh = read_bvh(path)
    except SfvError as exc:
        raise MotionFormatError(str(exc)) from None
    if "frame_count" in bvh.quirks:
        _warn_once(path, f"{path}: {bvh.quirks['frame_count']} (the whole frames are used)")
    names = [j.name for j in bvh.joints]
    rig_map = resolve_rig(rig, names, path)
    units = own_export_units(bvh) if rig_map.name == "sfv" else None
    if units is not None and (options.up, options.forward, options.units) == (None, None, None):
        motion = bvh_to_motion(bvh, units, path.stem, path)
        motion.loop = is_loop(motion.root_pos, motion.root_rot, motion.joint_rot) if options.loop is None else options.loop
        return motion, {"rig": "sfv", "units": units, "exact": True, "loop": motion.loop, FILE_REPORT: bvh.file_report()}
    motion, report = retarget(bvh, rig_map, options, path, path.stem)
    return motion, {**report, FILE_REPORT: bvh.file_report()}


def _warn_once(path: Path, message: str) -> None:
    """One line per file and process (a run loads its motion more than once)."""
    key = str(path.resolve())
    if key not in _warned:
        _warned.add(key)
        log.warning(message)


def load_bvh_clip(path: str | os.PathLike) -> ReferenceMotion:
    return import_bvh(path)[0]
