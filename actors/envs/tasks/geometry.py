"""Planar helpers shared by the tasks: vectors into each character's heading frame, angles."""
from __future__ import annotations

import numpy as np


def to_heading_frame(vectors: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """(B, 2) world vectors in each heading frame (x ahead, y left) for yaws (B,)."""
    c, s = np.cos(yaw), np.sin(yaw)
    x, y = vectors[:, 0], vectors[:, 1]
    return np.stack((c * x + s * y, -s * x + c * y), axis=1)


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    return (angle + np.pi) % (2.0 * np.pi) - np.pi


def polar(rng: np.random.Generator, distance: tuple[float, float], centre_angle: float, spread: float) -> np.ndarray:
    """A 2-D offset at U(distance) metres, at U(centre +- spread) radians."""
    angle = centre_angle + rng.uniform(-spread, spread)
    return rng.uniform(*distance) * np.array([np.cos(angle), np.sin(angle)])
