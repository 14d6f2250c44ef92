"""BlazePose person detector: letterboxed 224x224 input -> every person's box and
4 alignment keypoints in image pixels (best first).

Decoding follows MediaPipe's pose detection graph: raw box/keypoint offsets are in
input pixels relative to the anchor centre (x before y), scores are clipped logits
passed through a sigmoid, overlapping boxes are merged by weighted non-maximum
suppression (IoU 0.3). Keypoint 0 is the mid-hip centre, keypoint 1 a point whose
distance from it is the radius of a circle around the whole body; 2 and 3 do the
same for the upper body.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from learner.errors import SfvError
from services.pose.anchors import DETECTOR_INPUT_SIZE, ssd_anchor_centres
from services.pose.runtime import open_model

SCORE_CLIP = 100.0


@dataclass(frozen=True)
class PersonDetection:
    """One detected person in image pixels."""

    score: float
    box: np.ndarray        # (4,) x_min, y_min, x_max, y_max
    keypoints: np.ndarray  # (4, 2) alignment keypoints (x, y)


def letterbox_matrix(width: int, height: int, size: int = DETECTOR_INPUT_SIZE) -> np.ndarray:
    """2x3 affine taking image pixels into a size x size square, aspect kept, centred."""
    scale = size / max(width, height)
    pad_x = (size - width * scale) / 2.0
    pad_y = (size - height * scale) / 2.0
    return np.array([[scale, 0.0, pad_x], [0.0, scale, pad_y]], dtype=np.float64)


def _iou(box: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    x0 = np.maximum(box[0], boxes[:, 0])
    y0 = np.maximum(box[1], boxes[:, 1])
    x1 = np.minimum(box[2], boxes[:, 2])
    y1 = np.minimum(box[3], boxes[:, 3])
    inter = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
    area = (box[2] - box[0]) * (box[3] - box[1])
    areas = (boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1])
    return inter / np.maximum(area + areas - inter, 1e-12)


def weighted_nms(scores: np.ndarray, boxes: np.ndarray, keypoints: np.ndarray,
                 iou_threshold: float) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """MediaPipe's WEIGHTED suppression: each kept detection is the score-weighted mean
    of every remaining candidate overlapping the best one by more than `iou_threshold`."""
    order = np.argsort(-scores)
    remaining = order
    merged = []
    while remaining.size:
        best = remaining[0]
        overlap = _iou(boxes[best], boxes[remaining]) > iou_threshold
        members = remaining[overlap]
        weights = scores[members][:, None]
        box = (boxes[members] * weights).sum(0) / weights.sum()
        points = (keypoints[members] * weights[:, :, None]).sum(0) / weights.sum()
        merged.append((float(scores[best]), box, points))
        remaining = remaining[~overlap]
    return merged


class PoseDetector:
    """Runs pose_detection.tflite (or an .onnx of it) and returns the people it finds."""

    def __init__(self, model_path: str | Path, score_threshold: float = 0.5, iou_threshold: float = 0.3,
                 num_threads: int = 1):
        self.path = Path(model_path)
        self._model = open_model(self.path, num_threads)
        if self._model.input_shape[1:] != (DETECTOR_INPUT_SIZE, DETECTOR_INPUT_SIZE, 3):
            raise SfvError(f"{self.path}: not a BlazePose person detector (input shape {self._model.input_shape})")
        self._anchors = ssd_anchor_centres()
        self.score_threshold = score_threshold
        self.iou_threshold = iou_threshold
        self._input = np.zeros((1, DETECTOR_INPUT_SIZE, DETECTOR_INPUT_SIZE, 3), dtype=np.float32)
        self._square = np.zeros((DETECTOR_INPUT_SIZE, DETECTOR_INPUT_SIZE, 3), dtype=np.uint8)
        self.detect(np.zeros((DETECTOR_INPUT_SIZE, DETECTOR_INPUT_SIZE, 3), np.uint8))  # output check up front

    def detect(self, image_rgb: np.ndarray) -> PersonDetection | None:
        """Best person in an RGB uint8 image, or None when no score clears the threshold."""
        detections = self.detect_all(image_rgb)
        return detections[0] if detections else None

    def detect_all(self, image_rgb: np.ndarray) -> list[PersonDetection]:
        """Every person whose score clears the threshold, best first (after weighted NMS)."""
        height, width = image_rgb.shape[:2]
        to_input = letterbox_matrix(width, height)
        # INTER_AREA first: a straight bilinear warp from 1-2k pixels down to 224 aliases.
        scale = to_input[0, 0]
        resized = cv2.resize(image_rgb, (max(1, round(width * scale)), max(1, round(height * scale))),
                             interpolation=cv2.INTER_AREA)
        square = self._square
        square.fill(0)  # black letterbox bars, as MediaPipe's BORDER_ZERO
        top, left = int(round(to_input[1, 2])), int(round(to_input[0, 2]))
        rows, cols = min(resized.shape[0], DETECTOR_INPUT_SIZE - top), min(resized.shape[1], DETECTOR_INPUT_SIZE - left)
        square[top:top + rows, left:left + cols] = resized[:rows, :cols]
        np.multiply(square, 2.0 / 255.0, out=self._input[0], casting="unsafe")
        self._input -= 1.0
        outputs = self._model.run(self._input)
        raw_boxes, raw_scores = self._split_outputs(outputs)
        scores = 1.0 / (1.0 + np.exp(-np.clip(raw_scores.astype(np.float64), -SCORE_CLIP, SCORE_CLIP)))
        keep = scores >= self.score_threshold
        if not keep.any():
            return []
        boxes, keypoints = self._decode(raw_boxes[keep], self._anchors[keep])
        # letterboxed input pixels -> image pixels
        inverse = cv2.invertAffineTransform(to_input)
        detections = []
        for score, box, points in weighted_nms(scores[keep], boxes, keypoints, self.iou_threshold):
            points_px = points @ inverse[:, :2].T + inverse[:, 2]
            corners_px = box.reshape(2, 2) @ inverse[:, :2].T + inverse[:, 2]
            detections.append(PersonDetection(score=score, box=corners_px.ravel(), keypoints=points_px))
        return detections

    def _split_outputs(self, outputs: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """(2254, 12) regressors and (2254,) score logits, told apart by shape."""
        by_width = {value.shape[-1]: value for value in outputs.values()}
        anchors = len(self._anchors)
        if 12 not in by_width or 1 not in by_width or by_width[12].size != anchors * 12 or by_width[1].size != anchors:
            raise SfvError(f"{self.path}: not a BlazePose person detector (outputs {[v.shape for v in outputs.values()]})")
        return by_width[12].reshape(anchors, 12), by_width[1].reshape(anchors)

    @staticmethod
    def _decode(raw: np.ndarray, anchors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Raw (N, 12) offsets -> boxes (N, 4) and keypoints (N, 4, 2) in input pixels."""
        size = float(DETECTOR_INPUT_SIZE)
        centres = anchors * size
        box_centre = raw[:, 0:2] + centres
        half = raw[:, 2:4] / 2.0
        boxes = np.concatenate([box_centre - half, box_centre + half], axis=1)
        keypoints = raw[:, 4:12].reshape(-1, 4, 2) + centres[:, None, :]
        return boxes, keypoints
