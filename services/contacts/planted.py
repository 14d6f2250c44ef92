"""A foot that stands still in a static camera's picture while the body travels is down.

The contact network sees each 9-frame window relative to the hips (`features.py`), so that a
moving camera's pan carries no information; it therefore cannot see the plainest sign of a
stance in a static camera's video: the foot stays put in the picture while the body passes over
it. On a run filmed from the side (30 fps, 480 x 352, the runner 4 m/s), the network found 8 of
the 26 foot-frames with a foot down (by looking: right foot frames 0-11 and 23-29, left 14-20)
and none of the left foot's stance; its reference's stance feet skated at 3.2 m/s and the
controller leaned on the residual root force for 60 % of body weight.

For a static camera, a foot is taken as planted in a frame when all of these hold:
- the body travels across the picture: the hips' midpoint moves at MIN_TRAVEL_PACE keypoint
  spans per second or more (median over the frame and WINDOW_S either side; the span is the
  clip's median height of the keypoints, `support.keypoint_span`). A person standing or swaying
  keeps every foot about as still as the hips, a lifted one too, so stillness says nothing there
  and the network alone decides. The hips must move in the frame itself as well: a repeated
  frame (a frame-rate conversion; the run's first three frames are one picture) holds every
  point still;
- the foot's stillest sole point (heel, ankle or toe: a landing rolls on the heel, a push-off on
  the toe) moves in the picture at most PLANTED_RATIO of the hips' speed (the median above). On
  the run stance feet move at 0.06-0.48 of it and a swinging foot at 0.58 (just lifted) to 2.3;
  one half lies between, measured on that one clip, so a foot just lifting may read as down for
  a frame;
- the foot is seen (its sole points' mean confidence at least MIN_CONFIDENCE) and is not lifted
  above the other: its lowest sole point at most LIFT_SPANS of the span above the other foot's.

The planted frames are added to the network's flags (never taken away). Only a static camera
gets the rule (`track_contacts(static_camera=True)`); under a moving camera a planted foot moves
with the pan. A subject walking straight toward or away from the camera barely travels across
the picture and keeps the network's flags alone.
"""
from __future__ import annotations

import numpy as np

from services.contacts.support import hip_pace, keypoint_span

MIN_TRAVEL_PACE = 0.3  # keypoint spans per second: about 0.5 m/s for a person seen from the side
PLANTED_RATIO = 0.5
WINDOW_S = 0.2
MIN_CONFIDENCE = 0.5
LIFT_SPANS = 0.1


def planted_feet(points2d: np.ndarray, confidence: np.ndarray, fps: float, hips: list[int],
                 feet: list[list[int]]) -> np.ndarray:
    """(T, len(feet)) bool: each foot planted in each frame (module docstring). `points2d` (T, P, 2)
    pixels and `confidence` (T, P) of a static camera's track; `hips` the two hip points' indices;
    `feet` each foot's sole points (heel, ankle, toe), in the order of the contact arrays."""
    points = np.asarray(points2d, np.float64)
    frames = len(points)
    planted = np.zeros((frames, len(feet)), bool)
    span = keypoint_span(points, np.asarray(confidence))
    if frames < 3 or span <= 0:
        return planted
    pace = hip_pace(points, hips, span, fps)
    reach = max(1, int(round(WINDOW_S * fps)))
    travel = np.array([np.median(pace[max(0, t - reach): t + reach + 1]) for t in range(frames)])
    # the hips move in this frame too: a repeated frame (a frame-rate conversion, a frozen start) keeps every point still
    moving = (travel >= MIN_TRAVEL_PACE) & (pace >= MIN_TRAVEL_PACE)
    lowest = np.stack([points[:, foot, 1].max(axis=1) for foot in feet], axis=1)  # image y grows downward
    for f, foot in enumerate(feet):
        speed = np.linalg.norm(np.gradient(points[:, foot], axis=0), axis=-1).min(axis=1) * fps / span
        seen = np.asarray(confidence)[:, foot].mean(axis=1) >= MIN_CONFIDENCE
        other = np.delete(lowest, f, axis=1).max(axis=1) if len(feet) > 1 else lowest[:, f]
        not_lifted = lowest[:, f] >= other - LIFT_SPANS * span
        planted[:, f] = moving & (speed <= PLANTED_RATIO * travel) & seen & not_lifted
    return planted
