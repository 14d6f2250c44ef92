"""Adaptive sampling of experience tuples (dynamic-camera paper 002, §5.2, eq. 13).

Early termination makes a batch hold many tuples from the first frames of the reference and
few from the late ones. The paper evens this out per learning iteration: it counts the
tuples already in the memory buffer at each frame, n_t, and whenever an episode completes it
appends a fixed number K (32) of that episode's consecutive tuples, the start frame drawn with

    P(t) = (1 / (n_t + 1)) / sum_i (1 / (n_i + 1))                         (eq. 13)

over the starts the episode allows. `adaptive_tuple_mask` does this on one time-major PPO batch
and returns which tuples the update uses; advantages and value targets are computed on the full
trajectories before (the learner applies the mask after GAE / TD(lambda)), so a selected tuple's
target still sees every reward that followed it.

Where this differs from the paper, and why:

* **Unit = episode segment in this batch.** Workers ship fixed-length blocks of steps and PPO
  stays on-policy per iteration, so an episode that started in an earlier batch or runs on past
  this one cannot be held in a buffer until it completes. Each maximal run of one env's steps
  inside the batch that belongs to one episode (ended by `terminated`/`truncated`, or cut by the
  block's end) contributes K tuples. Dropping the cut segments instead would keep, of a 600-step
  episode in 64-step blocks, only its last block: the frames just before a fall.
* **Completion order.** Segments are appended in the order they end (block step, then env),
  as the paper appends episodes when they complete; n_t counts the tuples appended so far.
* **Short segments** (fewer than K tuples) contribute all their tuples (there is no window of
  K to place); they still raise n_t.
* n_t is indexed by the tuple's frame (the reference row of s_t); for a looped clip the row
  keeps counting through the horizon, so "frame" is time along the reference track, as the
  paper's video time is.

Measured (`bench/scripts/adaptive_sampling.py`, looped walk, 20 s horizon, 500 k samples): while episodes
are about as long as K (early training: ~53 steps), the short ones kept whole outweigh the cut
long ones, so the used tuples lean slightly *more* to the early frames than the collected ones;
learning per collected sample matched training on every tuple.
"""
from __future__ import annotations

import numpy as np

TUPLE_SAMPLING_MODES = ("all", "adaptive")


def episode_segments(ends: np.ndarray) -> list[tuple[int, int, int]]:
    """(env, first step, last step) of every episode segment of a (T, N) batch, in the order
    the segments end (step, then env). `ends[t, i]`: env i's episode ended at step t."""
    ends = np.asarray(ends, dtype=bool).copy()
    steps, envs = ends.shape
    ends[-1] = True  # the block's end cuts every running episode
    segments = []
    first = np.zeros(envs, dtype=np.int64)
    for t in range(steps):
        for i in np.flatnonzero(ends[t]):
            segments.append((int(i), int(first[i]), t))
            first[i] = t + 1
    return segments


def adaptive_tuple_mask(frames: np.ndarray, ends: np.ndarray, rng: np.random.Generator, tuples_per_episode: int = 32) -> np.ndarray:
    """The (T, N) boolean mask of the tuples eq. 13 selects.

    frames: (T, N) integer frame (reference row) of each tuple's state s_t, consecutive within
    an episode; ends: (T, N) bool, True where the episode ended at that step (terminated or
    truncated); tuples_per_episode: K, the paper's 32.
    """
    frames = np.asarray(frames)
    if frames.ndim != 2 or frames.shape != np.shape(ends) or 0 in frames.shape:
        raise ValueError(f"tuple sampling: frames {frames.shape} and ends {np.shape(ends)} must be equal non-empty (T, N) arrays")
    if tuples_per_episode < 1:
        raise ValueError(f"tuple sampling: tuples_per_episode must be >= 1, got {tuples_per_episode}")
    if frames.min() < 0:
        raise ValueError("tuple sampling: frame indices must be >= 0")
    counts = np.zeros(int(frames.max()) + 1, dtype=np.int64)  # n_t: tuples appended at frame t
    mask = np.zeros(frames.shape, dtype=bool)
    k = tuples_per_episode
    for env, first, last in episode_segments(ends):
        length = last - first + 1
        start = first
        if length > k:
            starts = frames[first:last - k + 2, env]  # the frames a window of K may start at
            weights = 1.0 / (counts[starts] + 1.0)
            start = first + int(rng.choice(len(starts), p=weights / weights.sum()))
        stop = min(start + k, last + 1)
        mask[start:stop, env] = True
        np.add.at(counts, frames[start:stop, env], 1)
    return mask


def coverage_stats(frames: np.ndarray, mask: np.ndarray | None = None) -> dict[str, float]:
    """How the tuples an update uses spread over the frames the batch reached (fixed metric names).

    used_fraction: used / collected tuples; frame_count_min / _max: fewest and most used tuples
    at any frame with at least one collected tuple; frame_entropy: entropy of the used-frame
    histogram over those frames, divided by its maximum (1 = every reached frame equally used).
    """
    frames = np.asarray(frames).ravel()
    used = frames if mask is None else frames[np.asarray(mask).ravel()]
    reached = np.bincount(frames) > 0
    counts = np.bincount(used, minlength=reached.size)[reached]
    p = counts[counts > 0] / max(counts.sum(), 1)
    entropy = float(-(p * np.log(p)).sum() / np.log(reached.sum())) if reached.sum() > 1 else 1.0
    return {
        "tuple_sampling/used_fraction": used.size / max(frames.size, 1),
        "tuple_sampling/frame_count_min": float(counts.min()),
        "tuple_sampling/frame_count_max": float(counts.max()),
        "tuple_sampling/frame_entropy": entropy,
    }


def frame_histogram(frames: np.ndarray, num_frames: int, bins: int = 32, mask: np.ndarray | None = None) -> list[int]:
    """Tuples (the masked ones, or all) per equal bin of the frame range [0, num_frames): a
    coarse per-frame coverage, small enough for one metrics row per iteration."""
    frames = np.asarray(frames).ravel()
    if mask is not None:
        frames = frames[np.asarray(mask).ravel()]
    index = np.minimum(frames.astype(np.int64) * bins // max(num_frames, 1), bins - 1)
    return np.bincount(index, minlength=bins).tolist()


def select_tuples(batch: dict, mode: str, tuples_per_episode: int, rng: np.random.Generator, num_frames: int) -> dict:
    """Apply the configured selection to a merged training batch (adds `update_mask` in adaptive
    mode) and return its coverage metrics; 'all' leaves the batch as it is."""
    frames = batch["frames"]
    mask = None
    if mode == "adaptive":
        ends = np.logical_or(batch["terminated"], batch["truncated"])
        mask = batch["update_mask"] = adaptive_tuple_mask(frames, ends, rng, tuples_per_episode)
    metrics = coverage_stats(frames, mask)
    metrics["tuple_sampling/collected_per_frame_bin"] = frame_histogram(frames, num_frames)
    metrics["tuple_sampling/used_per_frame_bin"] = frame_histogram(frames, num_frames, mask=mask)
    return metrics
