"""Text drawn over a frame with OpenCV: outlined so it stays legible on any background."""
from __future__ import annotations

import cv2
import numpy as np

WHITE = (255, 255, 255)
BLACK = (0, 0, 0)
PUSH_RED = (235, 60, 40)
FONT = cv2.FONT_HERSHEY_SIMPLEX


def text_scale(frame_width: int, frame_height: int, lines: list[str]) -> float:
    """Font scale for the frame height, shrunk so that the longest line fits the width."""
    scale = frame_height / 560.0
    widest = max(cv2.getTextSize(text, FONT, 1.0, 1)[0][0] for text in lines)
    return min(scale, 0.95 * frame_width / max(widest, 1))


def draw_lines(frame: np.ndarray, lines: list[tuple[str, tuple[int, int, int]]], scale: float | None = None) -> np.ndarray:
    """Draw (text, rgb colour) lines top-left; in place. `scale` defaults to `text_scale`."""
    height, width = frame.shape[:2]
    if scale is None:
        scale = text_scale(width, height, [text for text, _ in lines])
    thickness = max(1, round(scale * 1.5))
    line_height = int(round(30 * scale + 4))
    x, y = int(round(10 * scale + 2)), line_height
    # Darken the block behind the text (in place, no allocation) so it reads over the floor too.
    text_width = max(cv2.getTextSize(text, FONT, scale, thickness + 2)[0][0] for text, _ in lines)
    frame[: line_height * len(lines) + line_height // 3, : x + text_width + x] //= 3
    for text, colour in lines:
        cv2.putText(frame, text, (x, y), FONT, scale, BLACK, thickness + 2, cv2.LINE_AA)
        cv2.putText(frame, text, (x, y), FONT, scale, colour, thickness, cv2.LINE_AA)
        y += line_height
    return frame


def text_band(text: str, width: int, scale: float, colour=WHITE) -> np.ndarray:
    """A black band `width` pixels wide with `text` word-wrapped onto as many lines as it needs
    (a result line under a video: it covers none of the picture)."""
    thickness = max(1, round(scale * 1.5))
    line_height = int(round(30 * scale + 4))
    margin = int(round(10 * scale + 2))
    lines, current = [], ""
    for word in text.split():
        candidate = f"{current} {word}".strip()
        if current and cv2.getTextSize(candidate, FONT, scale, thickness)[0][0] > width - 2 * margin:
            lines.append(current)
            current = word
        else:
            current = candidate
    lines.append(current)
    rows = line_height * len(lines) + line_height // 3
    band = np.zeros((rows + rows % 2, width, 3), np.uint8)  # even: H.264 wants even frame sides
    for n, line in enumerate(lines):
        cv2.putText(band, line, (margin, line_height * (n + 1)), FONT, scale, colour, thickness, cv2.LINE_AA)
    return band
