"""What a motion file records about the video it came from, beyond SFV section 6's fit.

- video_start_frame: the video frame of motion frame 0 (the motion covers only the frames
  from the subject's first to last appearance, and `--frames`), read by `render-motion`.
- person_id: the identity followed (`sfv pose --people`).
- orientation_hint (T,) radians and orientation_hint_confidence (T,): the body-orientation
  hint of movingcam's eq. 7 (`orientation_hint.py`), per motion frame.
- camera_pan_px, camera_tilt_px, camera_zoom, camera_tracked (T,): the camera's motion into
  each frame (`services.pose.camera_path`), where the track measured it; camera_moving: the
  `--camera` decision (a moving camera also makes the motion root-free, `root_free.py`).
The learned foot-contact estimator's answer (contact_probability (T, 2), contacts (T, 2) bool,
contact_feet (right, left)) is not made here: the reconstruction takes `estimator.track_contacts`
as its contact estimate, fits the feet to it and records it (`services/contacts/video_motion.py`).
Older motion files lack these; readers take 0 for the first two.
"""
from __future__ import annotations

import numpy as np

from services.pose.camera_path import CameraPath
from services.reconstruction.orientation_hint import orientation_hint

def video_extras(track, path: CameraPath | None, camera_moving: bool) -> dict[str, np.ndarray]:
    """Extras of a motion reconstructed from `track` (a `services.pose.PoseTrack`) whose camera
    moved along `path` (None: the track did not measure it)."""
    hint, hint_confidence = orientation_hint(track.keypoints2d, track.confidence, tuple(track.keypoint_names),
                                             tuple(track.image_size))
    extras = {
        "video_start_frame": np.array(int(track.start_frame)),
        "person_id": np.array(int(track.person_id)),
        "orientation_hint": hint,
        "orientation_hint_confidence": hint_confidence,
        "camera_moving": np.array(bool(camera_moving)),
    }
    if path is not None:
        extras.update(camera_pan_px=path.pan_px, camera_tilt_px=path.tilt_px, camera_zoom=path.zoom,
                      camera_tracked=path.tracked)
    return extras


def video_start_frame(extras: dict) -> int:
    return int(extras.get("video_start_frame", 0))
