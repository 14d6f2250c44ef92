"""`sfv pose --people PREVIEW.png`: one row per identity, its first, middle and last
appearance cropped from the video, labelled with the id `--person` takes."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from learner.errors import SfvError
from services.pose.atomic import write_atomically
from services.pose.subject import PeopleTrack
from services.pose.video import read_frames

THUMB_W, THUMB_H, LABEL_H = 160, 200, 22
PAD = 0.15  # of the keypoint box's larger side, around each crop


def _frame(video: Path, index: int) -> np.ndarray:
    for _, frame in read_frames(video, index, index + 1):
        return frame
    raise SfvError(f"{video}: frame {index} cannot be decoded")


def _thumbnail(frame: np.ndarray, keypoints: np.ndarray) -> np.ndarray:
    low, high = keypoints.min(axis=0), keypoints.max(axis=0)
    pad = PAD * float(max(high - low))
    height, width = frame.shape[:2]
    x0, y0 = (int(max(0, v)) for v in low - pad)
    x1, y1 = int(min(width, high[0] + pad)), int(min(height, high[1] + pad))
    crop = frame[y0:max(y1, y0 + 1), x0:max(x1, x0 + 1)]
    scale = min(THUMB_W / crop.shape[1], THUMB_H / crop.shape[0])
    resized = cv2.resize(crop, (max(1, int(crop.shape[1] * scale)), max(1, int(crop.shape[0] * scale))),
                         interpolation=cv2.INTER_AREA)
    tile = np.full((THUMB_H, THUMB_W, 3), 30, np.uint8)
    top, left = (THUMB_H - resized.shape[0]) // 2, (THUMB_W - resized.shape[1]) // 2
    tile[top:top + resized.shape[0], left:left + resized.shape[1]] = resized
    return tile


def _label(text: str, width: int) -> np.ndarray:
    strip = np.full((LABEL_H, width, 3), 0, np.uint8)
    cv2.putText(strip, text, (4, LABEL_H - 6), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 255), 1, cv2.LINE_AA)
    return strip


def contact_sheet(people: PeopleTrack, video: Path) -> np.ndarray:
    """RGB image: per identity a label ("id N: frames A-B, seen in K") over three crops."""
    rows = []
    for summary in people.people():
        mine = np.flatnonzero(people.rows.person == summary.person)
        picks = [mine[0], mine[len(mine) // 2], mine[-1]]
        tiles = []
        for i in picks:
            frame_index = int(people.rows.frame[i])
            tile = _thumbnail(_frame(video, frame_index), people.rows.keypoints2d[i])
            cv2.putText(tile, f"f{frame_index}", (4, THUMB_H - 6), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (255, 255, 0), 1,
                        cv2.LINE_AA)
            tiles.append(tile)
        body = np.concatenate(tiles, axis=1)
        text = f"id {summary.person}: frames {summary.first_frame}-{summary.last_frame}, seen in {summary.frames_seen}"
        rows.append(np.concatenate([_label(text, body.shape[1]), body], axis=0))
    if not rows:
        raise SfvError(f"{video}: no person to preview")
    return np.concatenate(rows, axis=0)


def write_contact_sheet(people: PeopleTrack, video: Path, out: Path) -> Path:
    if out.suffix.lower() != ".png":
        raise SfvError(f"{out}: --people preview must be a .png file")
    if not out.parent.is_dir():
        raise SfvError(f"{out}: directory {out.parent} does not exist")
    ok, encoded = cv2.imencode(".png", cv2.cvtColor(contact_sheet(people, video), cv2.COLOR_RGB2BGR))
    if not ok:
        raise SfvError(f"{out}: PNG encoding failed")
    return write_atomically(out, lambda handle: handle.write(encoded.tobytes()))
