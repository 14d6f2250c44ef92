"""Quaternion helpers in numpy, scalar-first (w, x, y, z) like MuJoCo.

All functions broadcast over leading dimensions. `services/reconstruction/quaternion_torch.py` mirrors this
API for the differentiable forward kinematics used by motion reconstruction.
"""
from __future__ import annotations

import numpy as np

IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


def hamilton_product(a, b):
    """The four components (w, x, y, z) of a * b from the components of a and b: the one
    formula behind the numpy `quat_mul` here and the torch one of reconstruction."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.stack(hamilton_product(np.moveaxis(a, -1, 0), np.moveaxis(b, -1, 0)), axis=-1)


def quat_conj(q: np.ndarray) -> np.ndarray:
    return q * np.array([1.0, -1.0, -1.0, -1.0], dtype=q.dtype)


def quat_normalize(q: np.ndarray) -> np.ndarray:
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors v (..., 3) by unit quaternions q (..., 4)."""
    w = q[..., :1]
    u = q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def quat_from_axis_angle(rotvec: np.ndarray) -> np.ndarray:
    """Exponential map: rotation vector (axis * angle) -> unit quaternion."""
    angle = np.linalg.norm(rotvec, axis=-1, keepdims=True)
    half = 0.5 * angle
    # sin(x/2)/x -> 1/2 as x -> 0; the series keeps small angles exact.
    small = angle < 1e-8
    scale = np.where(small, 0.5 - angle**2 / 48.0, np.sin(half) / np.where(small, 1.0, angle))
    return np.concatenate((np.cos(half), rotvec * scale), axis=-1)


def quat_to_axis_angle(q: np.ndarray) -> np.ndarray:
    """Logarithm map: unit quaternion -> rotation vector with angle in [0, pi]."""
    q = np.where(q[..., :1] < 0.0, -q, q)
    v = q[..., 1:]
    s = np.linalg.norm(v, axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(s, q[..., :1])
    small = s < 1e-8
    scale = np.where(small, 2.0 / np.maximum(q[..., :1], 1e-12), angle / np.where(small, 1.0, s))
    return v * scale


def quat_angle(q: np.ndarray) -> np.ndarray:
    """Scalar rotation angle in [0, pi] of each quaternion (..., 4) -> (...)."""
    return 2.0 * np.arctan2(np.linalg.norm(q[..., 1:], axis=-1), np.abs(q[..., 0]))


def quat_about_axis(angle: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Quaternions for rotations by `angle` (...) about a fixed unit `axis` (3,)."""
    half = 0.5 * np.asarray(angle)[..., None]
    return np.concatenate((np.cos(half), np.sin(half) * axis), axis=-1)


def quat_slerp(q0: np.ndarray, q1: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Spherical interpolation along the shorter arc; t broadcasts as (...)."""
    t = np.asarray(t, dtype=np.float64)[..., None]
    dot = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(dot < 0.0, -q1, q1)
    dot = np.abs(dot)
    theta = np.arccos(np.clip(dot, -1.0, 1.0))
    sin_theta = np.sin(theta)
    near = sin_theta < 1e-6
    safe = np.where(near, 1.0, sin_theta)
    w0 = np.where(near, 1.0 - t, np.sin((1.0 - t) * theta) / safe)
    w1 = np.where(near, t, np.sin(t * theta) / safe)
    return quat_normalize(w0 * q0 + w1 * q1)


def heading_angle(q: np.ndarray) -> np.ndarray:
    """Yaw of the body's +x axis projected on the ground plane (Z up)."""
    forward = quat_rotate(q, np.array([1.0, 0.0, 0.0]))
    return np.arctan2(forward[..., 1], forward[..., 0])


def heading_quat(q: np.ndarray) -> np.ndarray:
    """The pure-yaw rotation that carries +x to the body's heading."""
    return quat_about_axis(heading_angle(q), np.array([0.0, 0.0, 1.0]))


def quat_to_mat(q: np.ndarray) -> np.ndarray:
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack(
        (
            np.stack((1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)), -1),
            np.stack((2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)), -1),
            np.stack((2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)), -1),
        ),
        axis=-2,
    )
