"""A walker is never in the air: short gaps with no foot down, at a walking pace, get the likelier foot.

The contact network calls a foot down where its probability is at least one half. On the park
walk (`sfv bench --suite videos --videos public`) it left 28 of her 141 frames with neither foot
down, in runs of 2-8 frames, while she walks at 1.3 m/s: a walk has no flight phase. There the
reconstruction's contact and slide terms hold no foot, both feet float, and the controller of
that reference leaned on the residual root force to hold the body up: 0.11 of body weight upward
on average over those frames against 0.015 with one foot down (`bench/scripts/help_direction.py`).
The network's second choice was often close (the left foot at 0.2-0.4 in frames 66-69).

A run of frames with no foot down is taken as missed support, and each of its frames gets the foot
of higher probability, when both hold:
- it lasts at most MAX_GAP_S (a run's flight lasts 0.1-0.15 s, so the pace decides it; a jump's
  flight of a quarter second or more is kept);
- the hips' midpoint moves in the image slower than FLIGHT_PACE keypoint spans per second, the
  median over the gap and WINDOW_S either side. The span is the clip's median height of the
  subject's keypoints in the image, about 0.85 of their stature; the median, because where the
  park walker passes the man on the box her hip keypoints jump at up to 3.7 spans/s for a few
  frames while she walks on. People walk up to about 2 m/s and run from there; the park walker
  (1.3 m/s, seen from the side) moves at 0.64 spans/s (median), and a jump's take-off (1.5 m/s
  or more) is about 1 span/s and more. A subject running toward the camera moves less in the
  image, so the rule reads such a run as a walk and may put a foot down in its flight (the
  limitation).
"""
from __future__ import annotations

import numpy as np

from services.reconstruction.plausibility import flag_runs

MAX_GAP_S = 0.25
FLIGHT_PACE = 1.3  # keypoint spans per second: about 2 m/s
WINDOW_S = 0.2
MIN_CONFIDENCE = 0.3  # keypoints seen well enough to measure the span


def keypoint_span(points2d: np.ndarray, confidence: np.ndarray) -> float:
    """The clip's median height in pixels of the subject's confidently seen keypoints."""
    seen = confidence >= MIN_CONFIDENCE
    heights = [np.ptp(frame[mask, 1]) for frame, mask in zip(points2d, seen) if mask.sum() >= 4]
    return float(np.median(heights)) if heights else 0.0


def hip_pace(points2d: np.ndarray, hips: list[int], span: float, fps: float) -> np.ndarray:
    """(T,) the hips' midpoint's image speed in keypoint spans per second (central differences)."""
    middle = points2d[:, hips].mean(axis=1)
    if len(middle) < 2 or span <= 0:
        return np.zeros(len(middle))
    return np.linalg.norm(np.gradient(middle, axis=0), axis=1) * fps / span


def fill_missed_support(flags: np.ndarray, probabilities: np.ndarray, pace: np.ndarray,
                        fps: float) -> tuple[np.ndarray, list[tuple[int, int]]]:
    """(flags with the missed support put down, the runs (first, last) filled); see the module
    docstring. `flags` and `probabilities` are (T, 2), `pace` (T,) in keypoint spans per second."""
    flags = np.asarray(flags, bool).copy()
    unsupported = ~flags.any(axis=1)
    longest = int(np.floor(MAX_GAP_S * fps + 1e-9))
    reach = int(round(WINDOW_S * fps))
    filled = []
    for first, last in flag_runs(unsupported):
        if last - first + 1 > longest:
            continue
        around = pace[max(0, first - reach): last + reach + 1]
        if around.size == 0 or np.median(around) >= FLIGHT_PACE:
            continue
        frames = np.arange(first, last + 1)
        flags[frames, np.argmax(probabilities[frames], axis=1)] = True
        filled.append((int(first), int(last)))
    return flags, filled

