"""Every person's answers over a range of video frames, as one flat table per chunk.

The chunk decodes `warmup_frames` frames before its first frame and keeps their rows too:
`services.pose.identity` matches the chunk's local track ids to the previous chunk's
identities on exactly those shared frames, so a chunk boundary does not reset identity.
Plain numpy arrays, so Ray ships a chunk cheaply.
"""
from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from services.pose.appearance import APPEARANCE_BINS
from services.pose.camera_motion import CameraMotionEstimator
from services.pose.config import PoseConfig
from services.pose.landmarks import NUM_BODY_LANDMARKS
from services.pose.models import PoseModelFiles
from services.pose.people import PeopleEstimator, PersonEstimate, keypoint_box
from services.pose.video import read_frames


@dataclass
class PeopleRows:
    """One row per (frame, person) answer; `person` is a local track id or a global identity."""

    frame: np.ndarray          # (N,) int32 video frame index
    person: np.ndarray         # (N,) int32
    keypoints2d: np.ndarray    # (N, 33, 2) float32 pixels
    confidence: np.ndarray     # (N, 33) float32 landmark visibility
    world3d: np.ndarray        # (N, 33, 3) float32 metres
    presence: np.ndarray       # (N,) float32
    rotation_used: np.ndarray  # (N,) int16 degrees
    roi_size: np.ndarray       # (N,) float32 side of the ROI the answer came from, pixels
    appearance: np.ndarray | None = None  # (N, APPEARANCE_BINS) float32 clothes' colours (`appearance.py`); zeros: unknown

    def __post_init__(self):
        if self.appearance is None:  # a table built without frames (tests, old callers): appearance unknown
            self.appearance = np.zeros((len(self.frame), APPEARANCE_BINS), np.float32)

    @classmethod
    def from_estimates(cls, rows: list[tuple[int, PersonEstimate]]) -> PeopleRows:
        joints = NUM_BODY_LANDMARKS
        if not rows:
            return cls(np.zeros(0, np.int32), np.zeros(0, np.int32), np.zeros((0, joints, 2), np.float32),
                       np.zeros((0, joints), np.float32), np.zeros((0, joints, 3), np.float32),
                       np.zeros(0, np.float32), np.zeros(0, np.int16), np.zeros(0, np.float32))
        poses = [e.pose for _, e in rows]
        return cls(
            frame=np.array([f for f, _ in rows], np.int32),
            person=np.array([e.local_id for _, e in rows], np.int32),
            keypoints2d=np.array([p.keypoints[:joints] for p in poses], np.float32),
            confidence=np.array([p.visibility[:joints] for p in poses], np.float32),
            world3d=np.array([p.world[:joints] for p in poses], np.float32),
            presence=np.array([p.presence for p in poses], np.float32),
            rotation_used=np.array([e.rotation_degrees for _, e in rows], np.int16),
            roi_size=np.array([p.roi.size for p in poses], np.float32),
            appearance=np.array([e.appearance if e.appearance is not None else np.zeros(APPEARANCE_BINS)
                                 for _, e in rows], np.float32).reshape(len(rows), APPEARANCE_BINS),
        )

    def select(self, mask: np.ndarray) -> PeopleRows:
        return PeopleRows(**{f.name: getattr(self, f.name)[mask] for f in fields(self)})

    def with_person(self, person: np.ndarray) -> PeopleRows:
        rows = self.select(np.ones(len(self.frame), bool))
        rows.person = np.asarray(person, np.int32)
        return rows

    @classmethod
    def concatenate(cls, parts: list[PeopleRows]) -> PeopleRows:
        return cls(**{f.name: np.concatenate([getattr(p, f.name) for p in parts]) for f in fields(cls)})

    def __len__(self) -> int:
        return len(self.frame)


@dataclass
class PeopleChunk:
    """Rows for frames first..stop-1 (first = start - warm-up); `decoded` frames of start..stop-1
    were read. camera_homography (decoded, 3, 3) / camera_inliers (decoded,): each own frame's
    camera motion from the frame before (`camera_motion.py`)."""

    start: int
    first: int
    decoded: int
    rows: PeopleRows
    camera_homography: np.ndarray
    camera_inliers: np.ndarray


def estimate_people_chunk(video: str | Path, start: int, stop: int, files: PoseModelFiles,
                          config: PoseConfig | None = None) -> PeopleChunk:
    """Everyone in frames start..stop-1 (and the warm-up frames before); serial or a Ray task."""
    config = config or PoseConfig()
    estimator, camera = PeopleEstimator(files, config), CameraMotionEstimator()
    first = max(0, start - config.warmup_frames)
    rows: list[tuple[int, PersonEstimate]] = []
    homographies, inliers = [], []
    for index, frame in read_frames(video, first, stop):
        estimates = estimator.process(frame)
        rows += [(index, estimate) for estimate in estimates]
        homography, count = camera.process(frame, [keypoint_box(e.pose) for e in estimates])
        if index >= start:
            homographies.append(homography)
            inliers.append(count)
    return PeopleChunk(start=start, first=first, decoded=len(homographies), rows=PeopleRows.from_estimates(rows),
                       camera_homography=np.array(homographies, np.float64).reshape(-1, 3, 3),
                       camera_inliers=np.array(inliers, np.int32))
