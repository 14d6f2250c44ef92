"""Where task episodes start: a random frame of one of the clips the experts know, moved to the origin.

004 Supp. D starts warehouse episodes from motion-capture frames of the matching phase; with
locomotion experts the matching frames are the walk's and the run's (a policy that only ever
starts at walking speed never learns to slow from a run). Every clip's frames are equally likely
as a whole: a clip is drawn first, then one of its frames. Both action spaces start alike, so
the comparison measures the policies, not the starts.
"""
from __future__ import annotations

import numpy as np

from actors.character.humanoid import PhysicsConfig
from actors.character.humanoid3d import Humanoid
from actors.motion.formats.io import load_motion
from actors.motion.reference_track import ReferenceTrack


def motion_names(start_motion: str) -> list[str]:
    """The clips of a comma-separated `start_motion` setting."""
    return [name.strip() for name in start_motion.split(",") if name.strip()]


class ClipStarts:
    def __init__(self, start_motion: str, physics: PhysicsConfig, control_dt: float):
        body = Humanoid(physics)
        self.qpos, self.qvel = [], []
        for name in motion_names(start_motion):
            track = ReferenceTrack(load_motion(name), body, control_dt, horizon_s=0.0)
            rows = track.start_steps
            qpos = track.qpos[:rows].copy()
            qpos[:, :2] = 0.0
            self.qpos.append(qpos)
            self.qvel.append(track.qvel[:rows].copy())

    def take(self, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """(qpos (43,), qvel (34,)) of a random frame of a random clip, root above the origin."""
        clip = int(rng.integers(len(self.qpos))) if len(self.qpos) > 1 else 0
        row = int(rng.integers(len(self.qpos[clip])))
        return self.qpos[clip][row], self.qvel[clip][row]
