"""What a motion file records about the video it came from, beyond SFV section 6's fit.

- video_start_frame: the video frame of motion frame 0 (the motion covers only the frames
  from the subject's first to last appearance, and `--frames`), read by `render-motion`.
- person_id: the identity followed (`sfv pose --people`).
- orientation_hint (T,) radians and orientation_hint_confidence (T,): the body-orientation
  hint of movingcam's eq. 7 (`orientation_hint.py`), per motion frame.
Older motion files lack these; readers take 0 for the first two.
"""
from __future__ import annotations

import numpy as np

from services.reconstruction.orientation_hint import orientation_hint


def video_extras(track) -> dict[str, np.ndarray]:
    """Extras of a motion reconstructed from `track` (a `services.pose.PoseTrack`)."""
    hint, hint_confidence = orientation_hint(track.keypoints2d, track.confidence, tuple(track.keypoint_names))
    return {
        "video_start_frame": np.array(int(track.start_frame)),
        "person_id": np.array(int(track.person_id)),
        "orientation_hint": hint,
        "orientation_hint_confidence": hint_confidence,
    }


def video_start_frame(extras: dict) -> int:
    return int(extras.get("video_start_frame", 0))
