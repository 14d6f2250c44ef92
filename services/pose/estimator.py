"""Per-frame BlazePose estimation over a range of video frames.

Each frame: track the ROI from the previous frame's auxiliary landmarks (re-detect when
pose presence drops), run the landmark model, and where the answer is not confident try
the frame rotated by 90, 180 and 270 degrees (SFV section 5 trains with rotated images;
with a fixed pretrained model we rotate at inference instead), keeping the most confident
answer that is temporally coherent with the previous frame.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from services.pose.config import PoseConfig
from services.pose.detector import PoseDetector
from services.pose.landmarks import NUM_BODY_LANDMARKS, FramePose, LandmarkModel
from services.pose.models import PoseModelFiles
from services.pose.roi import Roi, roi_from_alignment_points
from services.pose.video import read_frames

_ROTATE_CODES = {90: cv2.ROTATE_90_CLOCKWISE, 180: cv2.ROTATE_180, 270: cv2.ROTATE_90_COUNTERCLOCKWISE}


def rotate_frame(image: np.ndarray, degrees: int) -> tuple[np.ndarray, np.ndarray]:
    """The image turned clockwise by a multiple of 90 degrees, and the 2x3 affine taking
    pixels of the turned image back to the original."""
    height, width = image.shape[:2]
    back = {
        90: [[0, 1, 0], [-1, 0, height - 1]],
        180: [[-1, 0, width - 1], [0, -1, height - 1]],
        270: [[0, -1, width - 1], [1, 0, 0]],
    }[degrees]
    return cv2.rotate(image, _ROTATE_CODES[degrees]), np.asarray(back, dtype=np.float64)


def roi_in_original(roi: Roi, back: np.ndarray, degrees: int) -> Roi:
    """A ROI found in the frame turned by `degrees`, expressed in the original frame."""
    centre_x, centre_y = back[:, :2] @ [roi.centre_x, roi.centre_y] + back[:, 2]
    return Roi(float(centre_x), float(centre_y), roi.size, roi.rotation).rotated_by(-np.radians(degrees))


@dataclass(frozen=True)
class FrameEstimate:
    pose: FramePose | None
    rotation_degrees: int


@dataclass
class ChunkResult:
    """Answers for frames start..start+len-1; plain numpy arrays so Ray ships them cheaply."""

    start: int
    keypoints2d: np.ndarray  # (n, 33, 2) pixels
    confidence: np.ndarray   # (n, 33) landmark visibility
    world3d: np.ndarray      # (n, 33, 3) metres
    presence: np.ndarray     # (n,) pose presence
    valid: np.ndarray        # (n,) bool
    rotation_used: np.ndarray  # (n,) degrees

    @classmethod
    def empty(cls, start: int, frames: int) -> ChunkResult:
        joints = NUM_BODY_LANDMARKS
        return cls(start, np.zeros((frames, joints, 2), np.float32), np.zeros((frames, joints), np.float32),
                   np.zeros((frames, joints, 3), np.float32), np.zeros(frames, np.float32),
                   np.zeros(frames, bool), np.zeros(frames, np.int16))

    def truncated(self, frames: int) -> ChunkResult:
        return ChunkResult(self.start, self.keypoints2d[:frames], self.confidence[:frames], self.world3d[:frames],
                           self.presence[:frames], self.valid[:frames], self.rotation_used[:frames])

    def __len__(self) -> int:
        return len(self.valid)


def load_pose_models(files: PoseModelFiles, config: PoseConfig, score_threshold: float) -> tuple[PoseDetector, LandmarkModel]:
    """BlazePose's person detector (keeping detections above `score_threshold`) and its landmark model."""
    detector = PoseDetector(files.detector, score_threshold, config.nms_iou_threshold, config.num_threads)
    return detector, LandmarkModel(files.landmark, config.num_threads)


class FramePoseEstimator:
    """Stateful over consecutive frames: carries the tracked ROI and the last answer (one person:
    a still image for motion completion; videos go through `people.PeopleEstimator`)."""

    def __init__(self, files: PoseModelFiles, config: PoseConfig | None = None):
        self.config = config = config or PoseConfig()
        self.detector, self.landmarks = load_pose_models(files, config, config.detector_score_threshold)
        self.reset()

    def reset(self) -> None:
        self._roi: Roi | None = None
        self._previous: FramePose | None = None
        self._frames_since_previous = 0

    def process(self, image_rgb: np.ndarray) -> FrameEstimate:
        """Estimate the next frame (RGB uint8); `pose` is None when no person is found."""
        candidates: list[tuple[int, FramePose]] = []
        upright = self._track_or_detect(image_rgb)
        if upright is not None:
            candidates.append((0, upright))
        if upright is None or upright.score < self.config.rotation_threshold:
            for degrees in (90, 180, 270):
                rotated, back = rotate_frame(image_rgb, degrees)
                pose = self._detect_and_estimate(rotated)
                if pose is not None:
                    candidates.append((degrees, pose.transformed(back, roi_in_original(pose.roi, back, degrees))))
        chosen = self._choose(candidates)
        self._frames_since_previous += 1
        if chosen is None:
            self._roi = None
            return FrameEstimate(None, 0)
        degrees, pose = chosen
        self._roi = pose.next_roi()
        self._previous, self._frames_since_previous = pose, 0
        return FrameEstimate(pose, degrees)

    def _track_or_detect(self, image_rgb: np.ndarray) -> FramePose | None:
        if self._roi is not None:
            pose = self.landmarks.estimate(image_rgb, self._roi)
            if pose.presence >= self.config.presence_threshold:
                return pose
        return self._detect_and_estimate(image_rgb)

    def _detect_and_estimate(self, image_rgb: np.ndarray) -> FramePose | None:
        detection = self.detector.detect(image_rgb)
        if detection is None:
            return None
        roi = roi_from_alignment_points(detection.keypoints[0], detection.keypoints[1])
        return self.landmarks.estimate(image_rgb, roi)

    def _choose(self, candidates: list[tuple[int, FramePose]]) -> tuple[int, FramePose] | None:
        present = [c for c in candidates if c[1].presence >= self.config.presence_threshold]
        if not present:
            return None
        if self._previous is not None and self._frames_since_previous < self.config.coherence_window:
            coherent = [c for c in present if self._is_coherent(c[1])]
            present = coherent or present
        return max(present, key=lambda c: c[1].score)

    def _is_coherent(self, pose: FramePose) -> bool:
        previous = self._previous
        distance = np.linalg.norm(pose.keypoints[:NUM_BODY_LANDMARKS] - previous.keypoints[:NUM_BODY_LANDMARKS], axis=1).mean()
        return distance <= self.config.coherence_limit * previous.roi.size


def estimate_chunk(video: str | Path, start: int, stop: int, files: PoseModelFiles,
                   config: PoseConfig | None = None) -> ChunkResult:
    """Estimate frames start..stop-1, decoding `config.warmup_frames` earlier frames first
    so the chunk starts with a tracked ROI; the same function runs serially or as a Ray task."""
    config = config or PoseConfig()
    estimator = FramePoseEstimator(files, config)
    result = ChunkResult.empty(start, stop - start)
    decoded = 0
    for index, frame in read_frames(video, max(0, start - config.warmup_frames), stop):
        estimate = estimator.process(frame)
        if index < start:
            continue
        row = index - start
        decoded = row + 1
        if estimate.pose is None:
            continue
        pose = estimate.pose
        result.keypoints2d[row] = pose.keypoints[:NUM_BODY_LANDMARKS]
        result.confidence[row] = pose.visibility[:NUM_BODY_LANDMARKS]
        result.world3d[row] = pose.world[:NUM_BODY_LANDMARKS]
        result.presence[row] = pose.presence
        result.valid[row] = True
        result.rotation_used[row] = estimate.rotation_degrees
    return result.truncated(decoded)
