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
    warmup_frames: int = field(default=3, metadata={
        "help": "frames decoded before a chunk's first frame so that its ROIs are already tracked; "
                "identities are matched across the chunk boundary on these frames"})
    new_person_score_threshold: float = field(default=0.1, metadata={
        "help": "minimum detector score for a person no track covers yet to be tried; the landmark model's "
                "pose presence (presence_threshold) confirms or rejects it. Lower than "
                "detector_score_threshold because people under ~1/3 of the picture's height score 0.15-0.5"})
    detect_interval: int = field(default=4, metadata={
        "help": "every this many frames (and whenever nobody is tracked) the detector looks for people "
                "no track covers yet"})
    settle_rounds: int = field(default=4, metadata={
        "help": "times a new person's first answer is re-estimated on its own frame from the ROI its landmarks "
                "give, replacing the detector's (0: MediaPipe's behaviour, the first frame from the detector's ROI)"})
    settle_tolerance: float = field(default=0.03, metadata={
        "help": "ROI change (centre shift plus side change, fraction of its side) below which a new person's ROI "
                "has settled"})
    duplicate_iou: float = field(default=0.5, metadata={
        "help": "overlap (IoU) of two answers' keypoint boxes above which they are the same person "
                "(the newer track ends)"})
    stitch_limit: float = field(default=0.15, metadata={
        "help": "mean 2D keypoint distance, as a fraction of the ROI side, below which a track of one chunk "
                "continues a track of the previous chunk on their shared warm-up frames"})
    relink_gap_s: float = field(default=0.5, metadata={
        "help": "longest gap (seconds) across which a track that ended is continued by a new one"})
    relink_limit: float = field(default=0.3, metadata={
        "help": "mean 2D keypoint distance, as a fraction of the ROI side, between the last answer before a "
                "gap (moved on at its last speed) and the first after it for the two tracks to be one identity"})
    relink_max_gap_s: float = field(default=3.0, metadata={
        "help": "longest gap (seconds) across which a track is continued when its clothes match too "
                "(gaps over relink_gap_s need an appearance match)"})
    relink_spread_per_s: float = field(default=0.5, metadata={
        "help": "how much the position tolerance grows (ROI sides per second of gap beyond relink_gap_s): "
                "a hidden person may turn or change speed"})
    appearance_limit: float = field(default=0.5, metadata={
        "help": "Hellinger distance of two tracks' clothes colours above which they are two people "
                "(Pose2Sim two-people: one person's halves .06-.21, the two people .88-.98)"})
    switch_limit: float = field(default=0.65, metadata={
        "help": "appearance distance from a track's first answers above which (for switch_rows answers in "
                "a row) the track has slid onto someone else and is cut there (one person: at most .51)"})
    switch_rows: int = field(default=3, metadata={
        "help": "answers in a row past switch_limit that cut a track"})
    chunk_frames: int = field(default=50, metadata={
        "help": "frames per Ray task (also the chunking of the serial path, so both give the same answer)"})
    num_threads: int = field(default=1, metadata={
        "help": "threads per model interpreter; 1 because Ray runs one task per core"})
