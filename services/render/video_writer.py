"""MP4 writing with imageio-ffmpeg, atomic: frames go to a temp file that is renamed at the end."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from learner.atomic_io import usual_file_mode
from learner.errors import SfvError


def check_video_path(path: str | os.PathLike) -> Path:
    """The path as given, or a one-line SfvError if it cannot be an MP4 we write."""
    path = Path(path)
    if path.suffix.lower() != ".mp4":
        raise SfvError(f"{path}: the video must be an .mp4 file")
    if not path.resolve().parent.is_dir():
        raise SfvError(f"{path}: folder {path.resolve().parent} does not exist")
    return path



class AtomicVideoWriter:
    """`with AtomicVideoWriter(path, fps) as w: w.append(frame)`; on error nothing is left behind."""

    def __init__(self, path: str | os.PathLike, fps: float, quality: float = 7.0):
        import imageio.v2 as imageio

        self.path = check_video_path(path)
        fd, tmp = tempfile.mkstemp(prefix=f".{self.path.stem}.", suffix=".tmp.mp4", dir=self.path.parent)
        os.close(fd)
        self._tmp = Path(tmp)
        # macro_block_size 2: yuv420p needs even sizes only; imageio's default 16 would rescale frames.
        self._writer = imageio.get_writer(self._tmp, format="FFMPEG", fps=fps, codec="libx264", quality=quality,
                                          macro_block_size=2, ffmpeg_log_level="error")
        self.frames = 0

    def append(self, frame: np.ndarray) -> None:
        self._writer.append_data(frame)
        self.frames += 1

    def __enter__(self) -> "AtomicVideoWriter":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            self._writer.close()
        except Exception:
            self._tmp.unlink(missing_ok=True)
            raise
        if exc_type is None and self.frames > 0:
            os.chmod(self._tmp, usual_file_mode())  # mkstemp made it 0600
            os.replace(self._tmp, self.path)
        else:
            self._tmp.unlink(missing_ok=True)
