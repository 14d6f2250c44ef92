"""BlazePose landmark model: a 256x256 crop of a rotated ROI -> 39 landmarks.

Outputs (same names in the .tflite and its ONNX conversion):
  Identity   (1, 195): 39 x (x, y, z, visibility logit, presence logit), x/y/z in crop pixels
  Identity_1 (1, 1)  : pose presence, already a probability
  Identity_4 (1, 117): 39 x 3 world landmarks in metres, origin between the hips, axes of the crop
Landmarks 0..32 are the body; 33 (body centre) and 34 (body-circle point) only serve
to place the next frame's ROI. `LandmarkModel` hides which runtime runs the file.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from learner.errors import SfvError
from services.pose.roi import Roi, roi_from_alignment_points
from services.pose.runtime import open_model

LANDMARK_INPUT_SIZE = 256
NUM_LANDMARKS = 39
NUM_BODY_LANDMARKS = 33
AUX_CENTRE, AUX_SCALE = 33, 34


@dataclass(frozen=True)
class LandmarkOutput:
    """Raw landmark-model answer for one crop (crop pixels, crop-aligned world axes)."""

    landmarks: np.ndarray  # (39, 5) x, y, z, visibility logit, presence logit
    world: np.ndarray      # (39, 3) metres
    presence: float        # pose presence probability


@dataclass(frozen=True)
class FramePose:
    """One frame's landmarks mapped back to image pixels."""

    keypoints: np.ndarray   # (39, 2) image pixels
    visibility: np.ndarray  # (39,) probability the landmark is visible
    landmark_presence: np.ndarray  # (39,) probability the landmark is in the frame
    world: np.ndarray       # (39, 3) metres, hip-centred, image-aligned axes (x right, y down, z away from camera)
    presence: float         # pose presence probability
    roi: Roi                # region the landmarks came from

    @property
    def score(self) -> float:
        """Frame confidence: pose presence times mean body-landmark visibility."""
        return float(self.presence * self.visibility[:NUM_BODY_LANDMARKS].mean())

    def next_roi(self) -> Roi:
        """ROI for the following frame, from the auxiliary landmarks (MediaPipe's tracking)."""
        return roi_from_alignment_points(self.keypoints[AUX_CENTRE], self.keypoints[AUX_SCALE])

    def transformed(self, image_from_here: np.ndarray, roi: Roi) -> FramePose:
        """This pose seen through a 2x3 affine with a rotation-only linear part (used to
        map answers from a rotated copy of the frame back to the original frame)."""
        linear = image_from_here[:, :2]
        keypoints = self.keypoints @ linear.T + image_from_here[:, 2]
        world = self.world.copy()
        world[:, :2] = self.world[:, :2] @ linear.T
        return FramePose(keypoints, self.visibility, self.landmark_presence, world, self.presence, roi)


class LandmarkModel:
    """pose_landmark_full as .tflite (ai-edge-litert) or .onnx (onnxruntime), by extension."""

    def __init__(self, model_path: str | Path, num_threads: int = 1):
        self.path = Path(model_path)
        self._model = open_model(self.path, num_threads)
        if self._model.input_shape[1:] != (LANDMARK_INPUT_SIZE, LANDMARK_INPUT_SIZE, 3):
            raise SfvError(f"{self.path}: not a BlazePose landmark model (input shape {self._model.input_shape})")
        self._input = np.zeros((1, LANDMARK_INPUT_SIZE, LANDMARK_INPUT_SIZE, 3), dtype=np.float32)
        self.predict(np.zeros((LANDMARK_INPUT_SIZE, LANDMARK_INPUT_SIZE, 3), np.uint8))  # shape check up front

    def predict(self, crop_rgb: np.ndarray) -> LandmarkOutput:
        """Run on one 256x256 RGB uint8 crop (scaled to [0, 1] here)."""
        np.multiply(crop_rgb, 1.0 / 255.0, out=self._input[0], casting="unsafe")
        outputs = self._model.run(self._input)
        try:
            landmarks = outputs["Identity"].reshape(NUM_LANDMARKS, 5)
            presence = float(outputs["Identity_1"].reshape(-1)[0])
            world = outputs["Identity_4"].reshape(NUM_LANDMARKS, 3)
        except (KeyError, ValueError) as exc:
            raise SfvError(f"{self.path}: not a BlazePose landmark model (outputs {sorted(outputs)})") from exc
        return LandmarkOutput(landmarks=landmarks, world=world, presence=presence)

    def estimate(self, image_rgb: np.ndarray, roi: Roi) -> FramePose:
        """Warp the ROI out of the image, run the model, map landmarks back to image pixels."""
        crop_to_image = roi.crop_to_image(LANDMARK_INPUT_SIZE)
        crop = cv2.warpAffine(image_rgb, crop_to_image, (LANDMARK_INPUT_SIZE, LANDMARK_INPUT_SIZE),
                              flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP, borderMode=cv2.BORDER_REPLICATE)
        out = self.predict(crop)
        keypoints = out.landmarks[:, :2] @ crop_to_image[:, :2].T + crop_to_image[:, 2]
        rotation = crop_to_image[:, :2] / (roi.size / LANDMARK_INPUT_SIZE)  # pure rotation
        world = out.world.copy()
        world[:, :2] = out.world[:, :2] @ rotation.T
        return FramePose(
            keypoints=keypoints,
            visibility=_sigmoid(out.landmarks[:, 3]),
            landmark_presence=_sigmoid(out.landmarks[:, 4]),
            world=world,
            presence=out.presence,
            roi=roi,
        )


def _sigmoid(x: np.ndarray) -> np.ndarray:
    """The logistic function without overflow: exp of a non-positive number only (the model's
    visibility / presence logits reach -1000 and below on frames without the person)."""
    x = np.asarray(x)
    dtype = x.dtype if np.issubdtype(x.dtype, np.floating) else np.float64
    e = np.exp(-np.abs(x.astype(np.float64)))
    return np.where(x >= 0, 1.0 / (1.0 + e), e / (1.0 + e)).astype(dtype)
