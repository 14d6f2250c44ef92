"""Small videos that tests generate themselves (failure cases, short real clips)."""
from __future__ import annotations

from pathlib import Path

import cv2


def write_clip(path: Path, frames_rgb, fps: float = 60.0) -> Path:
    """Write RGB frames as an MJPG .avi/.mp4 that OpenCV reads back."""
    height, width = frames_rgb[0].shape[:2]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, (width, height))
    assert writer.isOpened()
    for frame in frames_rgb:
        writer.write(cv2.cvtColor(frame, cv2.COLOR_RGB2BGR))
    writer.release()
    return path
