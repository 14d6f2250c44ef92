"""How human-like a policy's movement is: each short window's distance to its nearest mocap window.

The pose-density score (`pose_prior.py`) looks at one pose at a time, and it ranks standing still
at z = 0 (25.8) above the mocap it was fitted to (17.7): a common pose held forever is likely. This
score compares movement. A window is WINDOW_FRAMES consecutive control steps of the 28 joint
coordinates and their velocities, each coordinate standardised by its spread over the library
(one spread per coordinate for poses, one for velocities); a window's distance is the RMS
standardised difference to the nearest library window. Lower is more human-like. The library is
every humanoid3d clip of `pose_prior.ALL_CLIPS` and its mirror.

Measured on that library (`reference_distances`, tests/services/tasks/test_motion_likeness.py):

| movement | distance |
|---|---|
| the library's own clips | 0 |
| standing still at the walk's first pose | .37 |
| the walk at half speed | .28 |
| each clip held out of the library, against the rest | .97 (walk .53, spinkick 1.47) |
| the walk with .1 rad of noise on every joint | 1.9 |
| random poses in [-1, 1] rad | 11.1 |

So it ranks the mocap above standing, and both far above jitter and flailing; a movement the
library has no example of (a clip held out) reads as far as 15 clips, a second or two each, leave
it. It does not say whether a policy moves: standing is near the library's slowest windows.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from services.tasks.pose_prior import ALL_CLIPS, clip_poses

WINDOW_FRAMES = 10  # a third of a second at 30 Hz: one step of a walk, the start of a turn
LIBRARY_STRIDE = 1  # every window of every clip: a clip scored against the library reads 0
QUERY_STRIDE = 5  # a policy's windows every 5 frames: 32 episodes of 10 s give about 1,900
CONTROL_HZ = 30.0
JOINT_COORDINATES = 28


def window_features(poses: np.ndarray, stride: int, control_hz: float = CONTROL_HZ) -> np.ndarray:
    """(M, F) windows of a (T, 28) pose sequence: the poses, then the joint velocities (rad/s)."""
    poses = np.asarray(poses, np.float64)
    width = WINDOW_FRAMES * JOINT_COORDINATES + (WINDOW_FRAMES - 1) * JOINT_COORDINATES
    if len(poses) < WINDOW_FRAMES:
        return np.zeros((0, width))
    velocities = np.diff(poses, axis=0) * control_hz
    starts = np.arange(0, len(poses) - WINDOW_FRAMES + 1, stride)
    pose_windows = np.stack([poses[s:s + WINDOW_FRAMES].ravel() for s in starts])
    velocity_windows = np.stack([velocities[s:s + WINDOW_FRAMES - 1].ravel() for s in starts])
    return np.concatenate([pose_windows, velocity_windows], axis=1)


@dataclass
class MotionLibrary:
    features: np.ndarray  # (L, F) standardised library windows
    clip_of: np.ndarray  # (L,) index into `clips` of each window's clip (a mirror counts as its clip)
    mean: np.ndarray
    scale: np.ndarray
    clips: tuple[str, ...]

    @classmethod
    def fit(cls, clips: tuple[str, ...] = ALL_CLIPS) -> "MotionLibrary":
        windows, owners = [], []
        for index, clip in enumerate(clips):
            for name in (clip, f"{clip}_mirror"):
                found = window_features(clip_poses(name), LIBRARY_STRIDE)
                windows.append(found)
                owners.append(np.full(len(found), index))
        raw = np.concatenate(windows)
        split = WINDOW_FRAMES * JOINT_COORDINATES
        pose_sd = raw[:, :split].reshape(len(raw), WINDOW_FRAMES, -1).std(axis=(0, 1))
        velocity_sd = raw[:, split:].reshape(len(raw), WINDOW_FRAMES - 1, -1).std(axis=(0, 1))
        scale = np.concatenate([np.tile(np.maximum(pose_sd, 1e-3), WINDOW_FRAMES),
                                np.tile(np.maximum(velocity_sd, 1e-2), WINDOW_FRAMES - 1)])
        mean = raw.mean(axis=0)
        return cls((raw - mean) / scale, np.concatenate(owners), mean, scale, tuple(clips))

    def distances(self, sequences: list[np.ndarray], exclude_clip: int | None = None) -> np.ndarray:
        """(M,) distance of every window of every (T, 28) sequence to its nearest library window
        (the windows of clip `exclude_clip` and its mirror left out)."""
        query = [w for w in (window_features(s, QUERY_STRIDE) for s in sequences) if len(w)]
        if not query:
            return np.zeros(0)
        q = (np.concatenate(query) - self.mean) / self.scale
        library = self.features if exclude_clip is None else self.features[self.clip_of != exclude_clip]
        # |q - l|^2 = |q|^2 + |l|^2 - 2 q.l: one matrix product (1,900 x 1,740 windows x 532: ~30 ms)
        squared = (q ** 2).sum(1)[:, None] + (library ** 2).sum(1)[None, :] - 2.0 * q @ library.T
        return np.sqrt(np.maximum(squared.min(axis=1), 0.0) / q.shape[1])

    def score(self, sequences: list[np.ndarray]) -> float | None:
        """The mean window distance of the sequences (None: none is WINDOW_FRAMES long)."""
        found = self.distances(sequences)
        return float(found.mean()) if len(found) else None

    def reference_distances(self) -> dict[str, float]:
        """The lines a policy's score reads against: each clip held out of the library against the
        rest (a human movement the library lacks), and standing still at the walk's first pose."""
        held_out = np.concatenate([self.distances([clip_poses(name)], exclude_clip=i)
                                   for i, clip in enumerate(self.clips) for name in (clip, f"{clip}_mirror")])
        first_pose = clip_poses("walk" if "walk" in self.clips else self.clips[0])[:1]
        standing = first_pose.repeat(int(3 * CONTROL_HZ), axis=0)
        return {"mocap_held_out": float(held_out.mean()), "standing_still": float(self.distances([standing]).mean())}
