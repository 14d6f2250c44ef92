"""The imitation reward of SFV §7.2: pose, velocity, end-effector and centre-of-mass terms.

r = w_p exp(-k_p sum_j |q*_j (-) q_j|^2) + w_v exp(-k_v sum_j |w*_j - w_j|^2)
  + w_e exp(-k_e sum_e |p*_e - p_e|^2) + w_c exp(-k_c |c* - c|^2)
with the paper's weights (.65, .1, .15, .1) and scales (2, 0.1, 40, 10).
- j runs over the root's world rotation and the 12 joints' local rotations. For a ball joint
  the angle of q*^-1 q is 2 acos|<q*, q>|; for a hinge it is the angle difference.
- Angular velocities are local: MuJoCo's qvel[3:] holds exactly the root's and each ball
  joint's local angular velocity and each hinge's rate (a hinge's |w* - w| is its rate gap).
- End effectors (ankles, wrists) are relative to the root in the heading frame; the centre
  of mass is in the world frame.
Weights and scales are config, so the other papers' variants plug in. Everything is
computed for a batch of envs at once (a single env is a batch of one).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from actors.features import HINGE_START, NUM_REWARD_QUATS, RewardFeatures


@dataclass(frozen=True)
class RewardConfig:
    pose_weight: float = field(default=0.65, metadata={"help": "w_p, weight of the joint-rotation term"})
    velocity_weight: float = field(default=0.1, metadata={"help": "w_v, weight of the joint angular-velocity term"})
    end_effector_weight: float = field(default=0.15, metadata={"help": "w_e, weight of the hands-and-feet position term"})
    com_weight: float = field(default=0.1, metadata={"help": "w_c, weight of the centre-of-mass term"})
    pose_scale: float = field(default=2.0, metadata={"help": "k_p in exp(-k_p * error)"})
    velocity_scale: float = field(default=0.1, metadata={"help": "k_v"})
    end_effector_scale: float = field(default=40.0, metadata={"help": "k_e"})
    com_scale: float = field(default=10.0, metadata={"help": "k_c"})

    @property
    def max_reward(self) -> float:
        return self.pose_weight + self.velocity_weight + self.end_effector_weight + self.com_weight


class ImitationReward:
    def __init__(self, config: RewardConfig = RewardConfig()):
        self.config = config
        c = config
        self._weights = np.array([c.pose_weight, c.velocity_weight, c.end_effector_weight, c.com_weight])
        self._scales = -np.array([c.pose_scale, c.velocity_scale, c.end_effector_scale, c.com_scale])
        self._scratch: dict[tuple[int, int], tuple] = {}  # per (B, D): work buffers and their views
        self._terms_views: tuple = (None,)

    def batch(self, sim: RewardFeatures, ref: RewardFeatures, terms: np.ndarray) -> np.ndarray:
        """Rewards (B,) and their four terms in `terms` (B, 4)."""
        diff, sums, sums_rest, hinge_sq, angle, rewards = self._buffers(sim.values.shape)
        if self._terms_views[0] is not terms:
            self._terms_views = (terms, terms[:, 0], terms[:, 1:])
        _, pose_term, other_terms = self._terms_views
        # Hinge angles, angular velocities, end effectors, centre of mass: squared differences
        # summed per segment in one pass over each row.
        np.subtract(sim.tail, ref.tail, out=diff)
        np.square(diff, out=diff)
        np.add.reduceat(diff, sim.segments, axis=1, out=sums)
        # The angle of q*^-1 q is 2 acos|<q*, q>|; hinges add their squared angle gap.
        np.vecdot(sim.quats, ref.quats, out=angle)
        np.abs(angle, out=angle)
        np.minimum(angle, 1.0, out=angle)
        np.arccos(angle, out=angle)
        angle *= 2.0
        np.vecdot(angle, angle, out=pose_term)
        pose_term += hinge_sq
        np.copyto(other_terms, sums_rest)
        np.multiply(terms, self._scales, out=terms)
        np.exp(terms, out=terms)
        return np.matmul(terms, self._weights, out=rewards)

    def _buffers(self, shape: tuple[int, int]) -> tuple:
        if shape not in self._scratch:
            b, width = shape
            sums = np.zeros((b, 4))
            self._scratch[shape] = (np.zeros((b, width - HINGE_START)), sums, sums[:, 1:], sums[:, 0],
                                    np.zeros((b, NUM_REWARD_QUATS)), np.zeros(b))
        return self._scratch[shape]

    def __call__(self, sim: RewardFeatures, ref: RewardFeatures, terms: np.ndarray | None = None) -> float:
        """Reward of a batch of one; `terms` (4,) receives the four terms if given."""
        t = np.zeros((1, 4)) if terms is None else terms.reshape(1, 4)
        return float(self.batch(sim, ref, t)[0])
