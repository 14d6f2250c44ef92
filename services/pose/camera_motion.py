"""How the camera moved between consecutive frames, from the background only.

Corner features (Shi-Tomasi) are picked in the previous frame outside every person's
keypoint box (grown by `PERSON_MARGIN`), followed into the current frame with pyramidal
Lucas-Kanade optical flow, kept when tracking back lands within `BACK_TRACK_PX` of the
start. RANSAC picks the inliers with a 4-degree-of-freedom similarity (pan, tilt, zoom and
roll), which cannot bend to fit two groups of points that move differently, and a
homography is then fitted to those inliers by least squares. It maps previous-frame pixels
to current-frame pixels (full resolution). The work is done on a copy at most
`WORK_WIDTH` pixels wide: camera motion is coarse, and this keeps it to ~3 ms a frame.
A frame with fewer than `MIN_INLIERS` RANSAC inliers is untracked: its homography is NaN.
Something large moving through a still view (a bus, a person's own backdrop) makes two
groups of points that a homography can bend to fit together; so when at least
`GROUP_FRACTION` of the points did not move (under `STILL_PX`) and as many moved clearly
(over `MOVING_PX`), the frame is taken as still. A camera motion does not split the points
like that: a slow pan moves all of them a little, a zoom moves them in proportion to their
distance from the centre (a logo burnt into the picture is rarely 30% of the corners).
(movingcam, 002 section 5.1, assumes a camera that pans, tilts and zooms but does not
roll; the homography is general, and `camera_path.py` reads pan, tilt and zoom off it.)
"""
from __future__ import annotations

import cv2
import numpy as np

WORK_WIDTH = 320
PERSON_MARGIN = 0.1
MAX_FEATURES = 200
MIN_INLIERS = 12
BACK_TRACK_PX = 1.0
RANSAC_PX = 1.5
STILL_PX = 0.3    # work pixels
MOVING_PX = 1.0
GROUP_FRACTION = 0.3


def background_mask(shape: tuple[int, int], boxes: list[np.ndarray], scale: float) -> np.ndarray:
    """uint8 mask (255 = background) of a work-size image, people's boxes (full-size pixels) cut out."""
    mask = np.full(shape, 255, np.uint8)
    for box in boxes:
        margin = PERSON_MARGIN * (box[2:] - box[:2])
        x0, y0 = np.floor((box[:2] - margin) * scale).astype(int)
        x1, y1 = np.ceil((box[2:] + margin) * scale).astype(int)
        mask[max(0, y0):max(0, y1), max(0, x0):max(0, x1)] = 0
    return mask


class CameraMotionEstimator:
    """Stateful over consecutive frames: keeps the previous work-size grey frame and its mask."""

    def __init__(self):
        self._previous: np.ndarray | None = None
        self._previous_mask: np.ndarray | None = None
        self._scale = 1.0

    def process(self, image_rgb: np.ndarray, person_boxes: list[np.ndarray]) -> tuple[np.ndarray, int]:
        """(3, 3) homography previous -> this frame (identity on the first frame, NaN when
        untracked) and the number of RANSAC inliers."""
        height, width = image_rgb.shape[:2]
        self._scale = min(1.0, WORK_WIDTH / width)
        size = (max(1, round(width * self._scale)), max(1, round(height * self._scale)))
        grey = cv2.cvtColor(cv2.resize(image_rgb, size, interpolation=cv2.INTER_AREA), cv2.COLOR_RGB2GRAY)
        mask = background_mask(grey.shape, person_boxes, self._scale)
        previous, previous_mask = self._previous, self._previous_mask
        self._previous, self._previous_mask = grey, mask
        if previous is None:
            return np.eye(3), 0
        return self._homography(previous, previous_mask & mask, grey)

    def _homography(self, previous: np.ndarray, mask: np.ndarray, grey: np.ndarray) -> tuple[np.ndarray, int]:
        untracked = np.full((3, 3), np.nan)
        start = cv2.goodFeaturesToTrack(previous, MAX_FEATURES, 0.01, 6, mask=mask)
        if start is None or len(start) < MIN_INLIERS:
            return untracked, 0
        moved, status, _ = cv2.calcOpticalFlowPyrLK(previous, grey, start, None, winSize=(21, 21), maxLevel=3)
        back, back_status, _ = cv2.calcOpticalFlowPyrLK(grey, previous, moved, None, winSize=(21, 21), maxLevel=3)
        good = (status[:, 0] == 1) & (back_status[:, 0] == 1) & (np.linalg.norm(back - start, axis=2)[:, 0] < BACK_TRACK_PX)
        if good.sum() < MIN_INLIERS:
            return untracked, int(good.sum())
        start, moved = start[good][:, 0], moved[good][:, 0]
        shift = np.linalg.norm(moved - start, axis=1)
        group = max(MIN_INLIERS, GROUP_FRACTION * len(start))
        still = int((shift < STILL_PX).sum())
        if still >= group and (shift > MOVING_PX).sum() >= group:
            return np.eye(3), still  # a still background and something large moving through it
        similarity, inliers = cv2.estimateAffinePartial2D(start, moved, method=cv2.RANSAC, ransacReprojThreshold=RANSAC_PX)
        count = int(inliers.sum()) if inliers is not None else 0
        if similarity is None or count < MIN_INLIERS:
            return untracked, count
        keep = inliers[:, 0] > 0
        homography, _ = cv2.findHomography(start[keep], moved[keep], 0)
        if homography is None:
            return untracked, count
        to_work = np.diag([self._scale, self._scale, 1.0])
        return np.linalg.inv(to_work) @ homography @ to_work, count
