"""Early termination on tracking deviation: the episode ends when the character is far from the reference.

DeepMimic ends an episode only when a forbidden link touches the ground (`actors/envs/falls.py`).
The tracking methods that learn hard skills in few samples also end it when the character has
drifted from the reference: MimicKit's DeepMimic env (`pose_termination`, the largest body
distance in the root frame, and the root's, against `pose_termination_dist`), PHC and
ProtoMotions (mean body-position error over 0.25-0.5 m). Past that point the samples teach
nothing about the skill (a character lying beside a backflip collects pose reward for its
limbs), and ending there turns "drifting away" into the same zero-return signal as a fall.

Measured here as the largest of: each end effector's distance to the reference's (both as
DeepMimic's reward sees them, offsets from the root in the heading frame with their height
above the ground) and the root's distance to the reference root (world, after the per-cycle
root sync). `EnvConfig.sfv.tracking_termination_m` is the threshold, 1.0 m by default (MimicKit's
distance; 0.5 m ended the roll's episodes after 23 control steps and learned worse), 0 turns it off.
Evaluation never uses it: strict falls are what `sfv eval` judges. At 1.0 m against off (`sfv eval`,
two workers x 32 envs): walk .981 at 2 M against .969, run .906 with no falls at 3 M against .855
at 7 M (with ballistic flight starts), getup_faceup .934 / getup_facedown .944 at 2 M against
.865 / .887 at 1 M, crawl .941 against .935, roll .706 against .382 at 5 M.
"""
from __future__ import annotations

import numpy as np

from actors.character.features import RewardFeatures


class TrackingTermination:
    """deviation(sim, ref) -> (B,) metres; __call__ -> (B,) bool over the threshold."""

    def __init__(self, threshold_m: float, batch: int = 1):
        if not threshold_m >= 0:
            raise ValueError(f"tracking termination distance must be >= 0 m, got {threshold_m}")
        self.threshold_m = float(threshold_m)
        self.active = self.threshold_m > 0
        self._ee = np.zeros((batch, 4, 3))
        self._root = np.zeros((batch, 3))
        self._dist = np.zeros((batch, 5))
        self._over = np.zeros(batch, dtype=bool)

    def deviation(self, sim: RewardFeatures, ref: RewardFeatures) -> np.ndarray:
        """(B,) largest distance (m) of an end effector or the root from the reference's."""
        np.subtract(sim.end_effectors, ref.end_effectors, out=self._ee)
        np.subtract(sim.root_pos, ref.root_pos, out=self._root)
        dist = self._dist
        np.sqrt(np.einsum("bkd,bkd->bk", self._ee, self._ee), out=dist[:, :4])
        np.sqrt(np.einsum("bd,bd->b", self._root, self._root), out=dist[:, 4])
        return dist.max(axis=1)

    def __call__(self, sim: RewardFeatures, ref: RewardFeatures) -> np.ndarray:
        """(B,) True where the deviation exceeds the threshold (all False when off)."""
        if not self.active:
            self._over[:] = False
            return self._over
        np.greater(self.deviation(sim, ref), self.threshold_m, out=self._over)
        return self._over
