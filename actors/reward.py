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
Weights and scales are config, so the other papers' variants plug in.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from actors.features import RewardFeatures


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


def pose_error_sq(sim: RewardFeatures, ref: RewardFeatures) -> float:
    """Sum over the 13 rotations of the squared angle of the difference rotation."""
    dot = np.abs(np.vecdot(sim.quats, ref.quats))
    angle = 2.0 * np.arccos(np.minimum(dot, 1.0))
    dh = sim.hinges - ref.hinges
    return float(angle @ angle + dh @ dh)


class ImitationReward:
    def __init__(self, config: RewardConfig = RewardConfig()):
        self.config = config
        c = config
        self._weights = np.array([c.pose_weight, c.velocity_weight, c.end_effector_weight, c.com_weight])
        self._scales = -np.array([c.pose_scale, c.velocity_scale, c.end_effector_scale, c.com_scale])
        self._errors = np.zeros(4)
        self._terms = np.zeros(4)

    def __call__(self, sim: RewardFeatures, ref: RewardFeatures, terms: np.ndarray | None = None) -> float:
        e = self._errors
        e[0] = pose_error_sq(sim, ref)
        dv = sim.ang_vel - ref.ang_vel
        e[1] = dv @ dv
        de = (sim.end_effectors - ref.end_effectors).ravel()
        e[2] = de @ de
        dc = sim.com - ref.com
        e[3] = dc @ dc
        t = self._terms if terms is None else terms
        np.exp(np.multiply(self._scales, e, out=t), out=t)
        return float(self._weights @ t)
