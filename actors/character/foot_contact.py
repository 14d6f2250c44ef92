"""Feet against the floor: where the soles are, how deep they sink, how much they slide.

Used by the retargeter to fit the ground and to report what it did. The sole is the foot
box of the ankle link (`skeleton.LINKS`); the floor is z = 0 (Z up, metres).

- Penetration: depth of the lowest sole corner below the floor (m), worst frame.
- Skating: mean horizontal speed (m/s) of an ankle while that foot is in contact, contact
  meaning the ankle within `CONTACT_BAND_M` of its own lowest height in the clip. The same
  rule is applied to the source skeleton's ankles, so the two figures compare directly.
"""
from __future__ import annotations

import itertools

import numpy as np

from actors.character import quaternion as qn
from actors.character.skeleton import LINK_NAMES, LINKS, yup_to_zup

FOOT_LINKS = (LINK_NAMES.index("right_ankle"), LINK_NAMES.index("left_ankle"))
CONTACT_BAND_M = 0.01
LOW_QUANTILE = 0.02  # the "lowest" height ignores the lowest 2 % of frames (mocap glitches)


def _sole_corners(link: int) -> np.ndarray:
    """(8, 3) corners of a foot box in its link frame (Z up)."""
    spec = LINKS[link]
    centre, half = np.asarray(spec.geom_offset_yup, np.float64), 0.5 * np.asarray(spec.size, np.float64)
    return np.stack([yup_to_zup(centre + half * np.array(signs)) for signs in itertools.product((-1, 1), repeat=3)])


SOLE_CORNERS = tuple(_sole_corners(link) for link in FOOT_LINKS)


def sole_heights(link_pos: np.ndarray, link_rot: np.ndarray) -> np.ndarray:
    """(T, 2) height of the lowest corner of each foot box (right, left)."""
    heights = []
    for link, corners in zip(FOOT_LINKS, SOLE_CORNERS):
        rot = np.broadcast_to(link_rot[:, link, None, :], link_rot.shape[:1] + corners.shape[:1] + (4,))
        world = link_pos[:, link, None, :] + qn.quat_rotate(rot, np.broadcast_to(corners, rot.shape[:-1] + (3,)))
        heights.append(world[..., 2].min(axis=1))
    return np.stack(heights, axis=1)


def penetration_depth(heights: np.ndarray) -> float:
    """Worst depth (m, >= 0) of a sole below the floor."""
    return float(max(0.0, -heights.min()))


def skating_speed(ankles: np.ndarray, dt: float) -> float:
    """Mean horizontal speed (m/s) of the ankles (T, 2, 3) while in contact (see module doc)."""
    speeds, counts = 0.0, 0
    for foot in range(ankles.shape[1]):
        track = ankles[:, foot]
        lowest = np.quantile(track[:, 2], LOW_QUANTILE)
        contact = track[:-1, 2] < lowest + CONTACT_BAND_M
        velocity = np.linalg.norm(np.diff(track[:, :2], axis=0), axis=-1) / dt
        speeds += float(velocity[contact].sum())
        counts += int(contact.sum())
    return speeds / max(counts, 1)
