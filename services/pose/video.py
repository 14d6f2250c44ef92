"""Decoding video frames with OpenCV, with one-line errors that name the file."""
from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from learner.errors import SfvError


@dataclass(frozen=True)
class VideoInfo:
    """What a chunked run needs to know about a video before decoding it."""

    path: Path
    frame_count: int
    fps: float
    width: int
    height: int


def _open(path: Path) -> cv2.VideoCapture:
    if not path.exists():
        raise SfvError(f"{path}: no such video file")
    if not path.is_file():
        raise SfvError(f"{path}: not a file")
    # One decoder thread: chunks already run one per core, extra threads only contend.
    capture = cv2.VideoCapture(str(path), cv2.CAP_ANY, [cv2.CAP_PROP_N_THREADS, 1])
    if not capture.isOpened():
        capture.release()
        raise SfvError(f"{path}: not a readable video (OpenCV cannot open it)")
    return capture


def probe_video(path: str | Path) -> VideoInfo:
    """Frame count, fps and size; counts frames by decoding when the container lies."""
    path = Path(path)
    capture = _open(path)
    try:
        ok, frame = capture.read()
        if not ok or frame is None:
            raise SfvError(f"{path}: video has no decodable frames")
        count = int(capture.get(cv2.CAP_PROP_FRAME_COUNT))
        fps = float(capture.get(cv2.CAP_PROP_FPS))
        if count <= 0:
            count = 1
            while capture.grab():
                count += 1
        height, width = frame.shape[:2]
    finally:
        capture.release()
    if not np.isfinite(fps) or fps <= 0:
        raise SfvError(f"{path}: video reports no frame rate")
    return VideoInfo(path=path, frame_count=count, fps=fps, width=width, height=height)


def read_frames(path: str | Path, start: int, stop: int) -> Iterator[tuple[int, np.ndarray]]:
    """Yield (index, RGB uint8 frame) for frames start..stop-1 (fewer if the file ends).

    Seeks with CAP_PROP_POS_FRAMES, which OpenCV's FFmpeg backend makes frame-exact
    (it decodes forward from the previous key frame).
    """
    path = Path(path)
    capture = _open(path)
    try:
        if start > 0:
            capture.set(cv2.CAP_PROP_POS_FRAMES, start)
        for index in range(start, stop):
            ok, frame = capture.read()
            if not ok or frame is None:
                return
            yield index, cv2.cvtColor(frame, cv2.COLOR_BGR2RGB)
    finally:
        capture.release()
