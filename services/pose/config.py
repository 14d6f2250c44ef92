"""Settings of the per-frame pose estimator."""
from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class PoseConfig:
    detector_score_threshold: float = field(default=0.5, metadata={
        "help": "minimum sigmoid score of a person detection"})
    nms_iou_threshold: float = field(default=0.3, metadata={
        "help": "IoU above which detections are merged (weighted NMS, as MediaPipe)"})
    presence_threshold: float = field(default=0.5, metadata={
        "help": "pose presence below which a frame has no person and tracking re-detects"})
    rotation_threshold: float = field(default=0.6, metadata={
        "help": "frame confidence (presence x mean visibility) below which the frame is also tried "
                "rotated by 90/180/270 degrees; > 1 tries them on every frame"})
    coherence_limit: float = field(default=0.25, metadata={
        "help": "max mean 2D keypoint distance to the previous answer, as a fraction of its ROI side, "
                "for a candidate to count as temporally coherent"})
    coherence_window: int = field(default=5, metadata={
        "help": "how many frames back the previous answer may lie and still be used for the coherence test"})
    warmup_frames: int = field(default=2, metadata={
        "help": "frames decoded before a chunk's first frame so that its ROI is already tracked"})
    chunk_frames: int = field(default=50, metadata={
        "help": "frames per Ray task (also the chunking of the serial path, so both give the same answer)"})
    num_threads: int = field(default=1, metadata={
        "help": "threads per model interpreter; 1 because Ray runs one task per core"})
