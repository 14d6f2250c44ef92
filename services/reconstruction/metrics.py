"""Error measures of a 3D joint trajectory against ground truth (both (T, J, 3), metres).

- MPJPE: mean joint distance after one similarity transform (rotation, uniform scale,
  translation; Umeyama) fitted over the whole clip.
- PA-MPJPE: the same with a similarity fitted to every frame separately, averaged.
- Acceleration error: mean over frames and joints of |a_pred - a_true|, a the second
  difference over frames, measured after the clip's similarity alignment.
`centre_on` subtracts a per-frame root point first (the hip midpoint), as is usual for
per-frame predictions that carry no global trajectory.
"""
from __future__ import annotations

import numpy as np


def similarity_transform(source: np.ndarray, target: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(scale, rotation (3, 3), translation (3,)) minimising |scale R source + t - target|^2
    over the rows of source and target (N, 3) (Umeyama 1991)."""
    mu_s, mu_t = source.mean(axis=0), target.mean(axis=0)
    s, t = source - mu_s, target - mu_t
    u, sigma, vt = np.linalg.svd(t.T @ s)
    sign = np.ones(3)
    sign[2] = np.sign(np.linalg.det(u @ vt)) or 1.0
    rotation = (u * sign) @ vt
    scale = float((sigma * sign).sum() / max((s * s).sum(), 1e-12))
    return scale, rotation, mu_t - scale * rotation @ mu_s


def apply_similarity(points: np.ndarray, transform) -> np.ndarray:
    scale, rotation, translation = transform
    return scale * points @ rotation.T + translation


def centre_on(points: np.ndarray, root_joints: list[int]) -> np.ndarray:
    return points - points[:, root_joints].mean(axis=1, keepdims=True)


def clip_aligned(predicted: np.ndarray, truth: np.ndarray) -> np.ndarray:
    transform = similarity_transform(predicted.reshape(-1, 3), truth.reshape(-1, 3))
    return apply_similarity(predicted, transform)


def mpjpe(predicted: np.ndarray, truth: np.ndarray) -> float:
    return float(np.linalg.norm(clip_aligned(predicted, truth) - truth, axis=-1).mean())


def pa_mpjpe(predicted: np.ndarray, truth: np.ndarray) -> float:
    errors = [np.linalg.norm(apply_similarity(p, similarity_transform(p, g)) - g, axis=-1).mean()
              for p, g in zip(predicted, truth)]
    return float(np.mean(errors))


def acceleration(points: np.ndarray) -> np.ndarray:
    return points[2:] - 2.0 * points[1:-1] + points[:-2]


def acceleration_error(predicted: np.ndarray, truth: np.ndarray) -> float:
    aligned = clip_aligned(predicted, truth)
    return float(np.linalg.norm(acceleration(aligned) - acceleration(truth), axis=-1).mean())


def evaluate(predicted: np.ndarray, truth: np.ndarray, root_joints: list[int]) -> dict[str, float]:
    """The three measures on hip-centred trajectories, in millimetres (per frame^2 for acceleration)."""
    p, g = centre_on(predicted, root_joints), centre_on(truth, root_joints)
    return {
        "mpjpe_mm": 1000.0 * mpjpe(p, g),
        "pa_mpjpe_mm": 1000.0 * pa_mpjpe(p, g),
        "accel_error_mm": 1000.0 * acceleration_error(p, g),
    }
