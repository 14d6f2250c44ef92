"""Write a file so that readers see either the old file or the complete new one."""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO

from learner.atomic_io import atomic_output


def write_atomically(path: Path, write: Callable[[BinaryIO], None]) -> Path:
    """Call `write(handle)` on a temp file beside `path`, then rename it over `path`.
    On any failure the temp file is removed and `path` is untouched."""
    with atomic_output(path, suffix=".part") as tmp, open(tmp, "wb") as handle:
        write(handle)
    return path
