"""The imitation reward of SFV §7.2: pose, velocity, end-effector and centre-of-mass terms.

r = w_p exp(-k_p sum_j |q*_j (-) q_j|^2) + w_v exp(-k_v sum_j |w*_j - w_j|^2)
  + w_e exp(-k_e sum_e |p*_e - p_e|^2) + w_c exp(-k_c |c* - c|^2)
with the paper's weights (.65, .1, .15, .1) and scales (2, 0.1, 40, 10). Rotations are the
root's world rotation and the 12 joints' local rotations; angular velocities are local;
end effectors (ankles, wrists) are relative to the root in the heading frame; the centre of
mass is in the world frame. Weights and scales are config, so variants plug in.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


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


def rotation_error_sq(sim: np.ndarray, ref: np.ndarray) -> float:
    """Sum over rotations of the squared angle of q_sim^-1 q_ref (the quaternion difference)."""
    # |w| of the difference quaternion is |<q_sim, q_ref>|; its angle is 2 acos(|w|).
    dot = np.abs(np.einsum("ij,ij->i", sim, ref))
    angle = 2.0 * np.arccos(np.minimum(dot, 1.0))
    return float(angle @ angle)


class ImitationReward:
    def __init__(self, config: RewardConfig = RewardConfig()):
        self.config = config

    def __call__(self, sim_rot, sim_ang_vel, sim_ee, sim_com, ref_rot, ref_ang_vel, ref_ee, ref_com, terms: np.ndarray | None = None) -> float:
        c = self.config
        pose = np.exp(-c.pose_scale * rotation_error_sq(sim_rot, ref_rot))
        dv = sim_ang_vel - ref_ang_vel
        vel = np.exp(-c.velocity_scale * float(np.vdot(dv, dv)))
        de = sim_ee - ref_ee
        ee = np.exp(-c.end_effector_scale * float(np.vdot(de, de)))
        dc = sim_com - ref_com
        com = np.exp(-c.com_scale * float(np.vdot(dc, dc)))
        if terms is not None:
            terms[:] = (pose, vel, ee, com)
        return c.pose_weight * pose + c.velocity_weight * vel + c.end_effector_weight * ee + c.com_weight * com
