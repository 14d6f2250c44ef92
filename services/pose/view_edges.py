"""A subject half out of the picture at its side: the frames of walking in and out of view.

BlazePose still reads a whole body when half of it is beyond the picture's edge, squeezing the
missing half inside. The park walk (`--videos public`) leaves at the left edge: over her last 8
frames her hips' midpoint goes from 5 % of the picture's width to its edge, and there the
reference she gave needed the most help of the clip, up to 0.33 of body weight upward and 0.39
sideways (`bench/scripts/help_direction.py`), and the clip's end was not cut: her root did
not jolt (`plausibility.unsettled_end`), it walked on with a body read wrong.

`at_the_sides(track)` counts the leading and trailing frames whose hips' midpoint lies within
EDGE_FRACTION of the picture's width from its left or right side. Only a clip's ends are cut, and
only when they are under MAX_CUT_FRACTION of it together: a subject who stays at the side (the
woman at the left edge of Pose2Sim two-people cam02) is left whole. Measured: the park walk 8
trailing frames; none of the eight Pose2Sim cameras (their subjects' hips stay within 0.34-0.60
of the width; an arm at the edge does not count).
"""
from __future__ import annotations

import numpy as np

from services.pose.activity import HIPS  # BlazePose's left and right hip

EDGE_FRACTION = 0.05
MAX_CUT_FRACTION = 1.0 / 3.0


def hip_position(track) -> np.ndarray:
    """(T,) the hips' midpoint's x as a fraction of the picture's width."""
    return np.asarray(track.keypoints2d, np.float64)[:, HIPS, 0].mean(axis=1) / float(track.image_size[0])


def at_the_sides(track) -> tuple[int, int]:
    """(leading frames, trailing frames) at the picture's sides; (0, 0) when they would take
    MAX_CUT_FRACTION of the clip or more."""
    x = hip_position(track)
    side = (x < EDGE_FRACTION) | (x > 1.0 - EDGE_FRACTION)
    lead = int(np.argmin(side)) if not side.all() else len(side)
    trail = int(np.argmin(side[::-1])) if not side.all() else len(side)
    if lead + trail >= MAX_CUT_FRACTION * len(side):
        return 0, 0
    return lead, trail
