"""Foot contacts drawn on the video half of `sfv render-motion`: at each ankle, a filled
yellow disc while the estimator says the foot is on the ground, a thin grey ring while it
is not; the disc's size grows with the contact probability."""
from __future__ import annotations

import cv2
import numpy as np

CONTACT_COLOUR, FREE_COLOUR, OUTLINE = (255, 220, 0), (170, 170, 170), (30, 30, 30)
ANKLES = {"right": "RAnkle", "left": "LAnkle"}


def draw_contacts(frame: np.ndarray, extras: dict, index: int, scale: np.ndarray, keypoint_names) -> None:
    """Mark frame `index`'s contacts (motions without `contacts` are left as they are)."""
    if "contacts" not in extras or index >= len(extras["contacts"]):
        return
    feet = [str(f) for f in extras.get("contact_feet", ("right", "left"))]
    for foot, (flag, probability) in zip(feet, zip(extras["contacts"][index], extras["contact_probability"][index])):
        point = extras["keypoints2d"][index][list(keypoint_names).index(ANKLES[foot])] * scale
        centre = tuple(int(v) for v in np.round(point))
        if flag:
            radius = int(round(5 + 5 * float(probability)))
            cv2.circle(frame, centre, radius + 1, OUTLINE, -1, cv2.LINE_AA)
            cv2.circle(frame, centre, radius, CONTACT_COLOUR, -1, cv2.LINE_AA)
        else:
            cv2.circle(frame, centre, 7, FREE_COLOUR, 1, cv2.LINE_AA)
