"""What a motion file records about the video it came from, beyond SFV section 6's fit.

- video_start_frame: the video frame of motion frame 0 (the motion covers only the frames
  from the subject's first to last appearance, and `--frames`), read by `render-motion`.
- person_id: the identity followed (`sfv pose --people`).
Older motion files lack these; readers take 0 for both.
"""
from __future__ import annotations

import numpy as np


def video_extras(track) -> dict[str, np.ndarray]:
    """Extras of a motion reconstructed from `track` (a `services.pose.PoseTrack`)."""
    return {
        "video_start_frame": np.array(int(track.start_frame)),
        "person_id": np.array(int(track.person_id)),
    }


def video_start_frame(extras: dict) -> int:
    return int(extras.get("video_start_frame", 0))
