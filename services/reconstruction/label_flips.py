"""Undoing left/right label swaps of the pose estimator by temporal coherence.

Seen from behind or from the side, a per-frame estimator sometimes reads the body the other
way round: it calls the right shoulder "left" and, to match the image, predicts a body that
faces the camera instead of away from it. That reading is the true pose reflected in depth
(z -> -z about the hips, which leaves the image unchanged) with left and right swapped, so it
is undone by swapping the labels back and reflecting the depth again.

Which frames to undo is a chain over the two readings (as read / swapped), solved exactly by
Viterbi. A path costs how far the labelled points jump between frames (2D jumps as a
fraction of the person's height in pixels plus 3D jumps as a fraction of their height in
metres), both between adjacent frames and between frames two apart, plus a small price for
every frame whose reading is overruled, so that the estimator's own labels win whenever the
motion gives no reason to doubt them. The two-frame jumps carry the chain across a
degenerate frame (left and right on top of each other in the image), where both readings
look alike and adjacent jumps alone cannot tell where a wrong reading starts. Like the
90-degree rotations of the pose stage (Yu et al. 2021, section 4), the choice between
candidate readings is made by temporal coherence and confidence.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from services.reconstruction.keypoints import LEFT_RIGHT_SWAP, ObservedPoints

DEPTH_REFLECTION = np.array([1.0, 1.0, -1.0])


def mirrored_reading(obs: ObservedPoints) -> ObservedPoints:
    """The other reading of every frame: labels swapped, depth reflected about the hips."""
    return replace(
        obs,
        keypoints2d=obs.keypoints2d[:, LEFT_RIGHT_SWAP],
        confidence=obs.confidence[:, LEFT_RIGHT_SWAP],
        points3d=obs.points3d[:, LEFT_RIGHT_SWAP] * DEPTH_REFLECTION,
    )


def _person_heights(obs: ObservedPoints) -> tuple[float, float]:
    """Median vertical extent of the body in pixels and in metres (over confident frames)."""
    frames = obs.valid & (obs.confidence.max(axis=1) > 0)
    if not frames.any():
        return 1.0, 1.0
    pixels = np.ptp(obs.keypoints2d[frames, :, 1], axis=1)
    metres = np.ptp(obs.points3d[frames, :, 1], axis=1)
    return max(float(np.median(pixels)), 1.0), max(float(np.median(metres)), 1e-3)


def _jump_costs(a: ObservedPoints, b: ObservedPoints, lag: int, height_px: float, height_m: float) -> np.ndarray:
    """(T-lag,) cost of going from frame t of reading a to frame t+lag of reading b."""
    weight = np.minimum(a.confidence[:-lag], b.confidence[lag:])
    jump_2d = np.linalg.norm(b.keypoints2d[lag:] - a.keypoints2d[:-lag], axis=-1)
    cost_2d = (weight * jump_2d).sum(-1) / np.maximum(weight.sum(-1), 1e-9) / height_px
    jump_3d = np.linalg.norm(b.points3d[lag:] - a.points3d[:-lag], axis=-1).mean(-1) / height_m
    return cost_2d + jump_3d


def _pairwise(readings, lag: int, height_px: float, height_m: float) -> np.ndarray:
    """(2, 2, T-lag): [a, b, t] the cost of reading a at t followed by reading b at t+lag."""
    return np.array([[_jump_costs(readings[a], readings[b], lag, height_px, height_m) for b in range(2)] for a in range(2)])


def find_label_flips(obs: ObservedPoints, overrule_cost: float = 0.02) -> np.ndarray:
    """(T,) bool: frames whose reading should be swapped (the cheapest path of the chain).

    The chain's state at frame t is the pair of readings (at t-1, at t), so that a step can
    pay for both the adjacent jump and the jump from t-2.
    """
    frames = len(obs)
    if frames < 2:
        return np.zeros(frames, dtype=bool)
    readings = (obs, mirrored_reading(obs))
    height_px, height_m = _person_heights(obs)
    step = _pairwise(readings, 1, height_px, height_m)
    skip = _pairwise(readings, 2, height_px, height_m) if frames > 2 else None
    unary = np.array([0.0, overrule_cost])
    cost = unary[:, None] + unary[None, :] + step[:, :, 0]  # [reading at t-1, reading at t], t = 1
    back = np.zeros((frames, 2, 2), dtype=int)  # back[t, b, c]: best reading at t-2 given b at t-1, c at t
    for t in range(2, frames):
        options = cost[:, :, None] + step[None, :, :, t - 1] + skip[:, None, :, t - 2]  # [a, b, c]
        back[t] = options.argmin(axis=0)
        cost = options.min(axis=0) + unary[None, :]
    previous, current = np.unravel_index(int(cost.argmin()), cost.shape)
    path = [current, previous]
    for t in range(frames - 1, 1, -1):
        earlier = back[t, previous, current]
        path.append(earlier)
        previous, current = earlier, previous
    return np.array(path[::-1], dtype=bool)


def undo_label_flips(obs: ObservedPoints, flips: np.ndarray) -> ObservedPoints:
    mirrored = mirrored_reading(obs)
    pick = lambda ours, theirs: np.where(flips.reshape((-1,) + (1,) * (ours.ndim - 1)), theirs, ours)
    return replace(
        obs,
        keypoints2d=pick(obs.keypoints2d, mirrored.keypoints2d),
        confidence=pick(obs.confidence, mirrored.confidence),
        points3d=pick(obs.points3d, mirrored.points3d),
    )
