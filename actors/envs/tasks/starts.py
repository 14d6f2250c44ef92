"""Where task episodes start: a random frame of a clip the experts know, moved to the origin.

004 Supp. D starts warehouse episodes from motion-capture frames of the matching phase; with
locomotion experts the matching frames are the walk's. Both action spaces start alike, so the
comparison measures the policies, not the starts.
"""
from __future__ import annotations

import numpy as np

from actors.character.humanoid import PhysicsConfig
from actors.character.humanoid3d import Humanoid
from actors.motion.formats.io import load_motion
from actors.motion.reference_track import ReferenceTrack


class ClipStarts:
    def __init__(self, motion_name: str, physics: PhysicsConfig, control_dt: float):
        track = ReferenceTrack(load_motion(motion_name), Humanoid(physics), control_dt, horizon_s=0.0)
        rows = track.start_steps
        self.qpos = track.qpos[:rows].copy()
        self.qvel = track.qvel[:rows].copy()
        self.qpos[:, :2] = 0.0

    def take(self, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """(qpos (43,), qvel (34,)) of a random frame, root above the origin."""
        row = int(rng.integers(len(self.qpos)))
        return self.qpos[row], self.qvel[row]
