"""How human-like a task policy's poses are: their mean log-density under a pose prior.

The prior is a Gaussian mixture with one component per expert clip (every humanoid3d clip in
pybullet_data by default; mirrored clips are left out), each fitted to that clip's poses at the
control rate, with equal weights. A pose is the 28 joint coordinates the PD targets live in
(rotation vectors of the 8 ball joints, the 4 hinge angles: MuJoCo's actuator lengths), the
root excluded, so the score says how the body is held, not where it goes. A clip has tens to a
few hundred frames for 28 dimensions, so each covariance is shrunk towards (0.1 rad)^2 I: a
pose 0.1 rad off a clip in every joint is still plausible, a flailing one is not.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SHRINK_RAD = 0.1
ALL_CLIPS = ("backflip", "cartwheel", "crawl", "dance_a", "dance_b", "getup_facedown", "getup_faceup", "jump", "kick",
             "punch", "roll", "run", "spin", "spinkick", "walk")


def clip_poses(clip: str, control_hz: float = 30.0) -> np.ndarray:
    """(T, 28) joint coordinates of a DeepMimic clip's frames at the control rate."""
    from actors.character.humanoid3d import Humanoid
    from actors.motion.formats.io import load_motion
    from actors.motion.reference_track import ReferenceTrack

    track = ReferenceTrack(load_motion(f"deepmimic:{clip}"), Humanoid(), 1.0 / control_hz, horizon_s=0.0)
    return track.ctrl[:track.start_steps].copy()


@dataclass
class PosePrior:
    means: np.ndarray  # (C, 28)
    precisions: np.ndarray  # (C, 28, 28)
    log_norms: np.ndarray  # (C,): log weight + Gaussian normaliser per component
    clips: tuple[str, ...]

    @classmethod
    def fit(cls, clips: tuple[str, ...] = ALL_CLIPS) -> "PosePrior":
        means, precisions, log_norms = [], [], []
        for clip in clips:
            poses = clip_poses(clip)
            mean = poses.mean(axis=0)
            cov = np.cov(poses, rowvar=False) + SHRINK_RAD ** 2 * np.eye(poses.shape[1])
            sign, logdet = np.linalg.slogdet(cov)
            means.append(mean)
            precisions.append(np.linalg.inv(cov))
            log_norms.append(-np.log(len(clips)) - 0.5 * (logdet + poses.shape[1] * np.log(2 * np.pi)))
        return cls(np.array(means), np.array(precisions), np.array(log_norms), tuple(clips))

    def log_density(self, poses: np.ndarray) -> np.ndarray:
        """(N,) log p(pose) under the mixture."""
        diff = poses[:, None, :] - self.means[None]  # (N, C, 28)
        maha = np.einsum("nci,cij,ncj->nc", diff, self.precisions, diff)
        terms = self.log_norms[None] - 0.5 * maha
        top = terms.max(axis=1, keepdims=True)
        return (top + np.log(np.exp(terms - top).sum(axis=1, keepdims=True)))[:, 0]
