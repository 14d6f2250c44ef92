"""The dynamic-camera paper's tracking reward (002 §5.1, eq. 5-9), batched over B envs.

r_track = w_q r_q + w_v r_v + w_ori r_ori + w_c r_contact + w_reg r_reg, each r = exp(-alpha E):

- E_q (eq. 6): sum (or, by default, mean: `joint_error`) over the 12 joints of the squared joint-angle error: ball joints the angle
  of q*^-1 q (2 acos|<q*, q>|), hinges the angle gap. The root's rotation is not a joint:
  "the pose and velocity vectors do not provide any information about the root position
  and orientation".
- E_v (eq. 6): sum (by default mean) of squared differences of the joints' velocity coordinates (MuJoCo's
  qvel[6:]: each ball joint's local angular velocity, each hinge's rate; the paper's finite
  differences of joint angles, which the reference's velocities are).
- E_ori (eq. 7): (|h| - theta)^2 with theta the simulated pelvis-to-neck vector's angle
  from the world's up axis. Reconciling the stored hint with eq. 7: the motion's
  `orientation_hint` is the *signed 2D* angle in the image between the picture's up and the
  pelvis-to-neck vector (`services/reconstruction/orientation_hint.py`); eq. 7 compares it
  with a *3D* angle against the up axis, which has no sign. So the hint's magnitude is what
  is compared (deviation from the paper's notation, which leaves this implicit). For a
  camera that does not roll, the projected angle is at most the 3D tilt (equal when the
  lean is across the line of sight, smaller when along it), so the term pulls the tilt
  towards the visible lean. Hint frames below the confidence floor weigh 0
  (`actors/envs/modes/movingcam/targets.py`). A mocap clip's hint is the clip's own 3D tilt, exact.
- E_c (eq. 8): number of end effectors whose simulated contact differs from the flag (XOR):
  the feet, and the hands when the motion has hand flags.
- E_reg (eq. 9): sum of squared actuator torques, each divided by its actuator's torque
  limit (deviation: the paper gives no units; raw N m with alpha 1 would make the term 0
  for every pose that holds the body up, so it would carry no signal).

Weights .35/.1/.2/.25/.1 and alphas 12/.6/5/2/1 are the paper's. The scene reward (eq. 10-12)
is added by the env when it has a scene (`ImitationEnv` / the vector env), not here.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from actors.character.features import RewardFeatures

JOINT_ERROR_FORMS = ("mean", "sum")
TERM_NAMES = ("joint_angle", "joint_velocity", "orientation", "contact", "torque")
NUM_TERMS = len(TERM_NAMES)


@dataclass(frozen=True)
class MovingcamRewardConfig:
    joint_error: str = field(default="mean", metadata={"choices": JOINT_ERROR_FORMS, "help": "mean: E_q and E_v averaged over the joints and joint-velocity coordinates; sum: summed, as eq. 6 prints it (sums leave no signal: docs/training.md)"})
    joint_angle_weight: float = field(default=0.35, metadata={"help": "w_q, weight of the joint-angle term (002 eq. 6)"})
    joint_velocity_weight: float = field(default=0.1, metadata={"help": "w_v, weight of the joint-velocity term (eq. 6)"})
    orientation_weight: float = field(default=0.2, metadata={"help": "w_ori, weight of the body up-vector term against the video's hint (eq. 7)"})
    contact_weight: float = field(default=0.25, metadata={"help": "w_contact, weight of the contact-flag term (eq. 8)"})
    torque_weight: float = field(default=0.1, metadata={"help": "w_reg, weight of the joint-torque regulariser (eq. 9)"})
    joint_angle_scale: float = field(default=12.0, metadata={"help": "alpha_q on the sum over 12 joints of squared angle errors (rad^2)"})
    joint_velocity_scale: float = field(default=0.6, metadata={"help": "alpha_v on the sum of squared joint-velocity errors ((rad/s)^2)"})
    orientation_scale: float = field(default=5.0, metadata={"help": "alpha_ori on the squared gap between |hint| and the simulated pelvis-to-neck tilt (rad^2)"})
    contact_scale: float = field(default=2.0, metadata={"help": "alpha_c on the number of end effectors whose contact differs from the flag"})
    torque_scale: float = field(default=1.0, metadata={"help": "alpha_reg on the sum of squared torques, each over its actuator's limit"})

    def __post_init__(self):
        if self.joint_error not in JOINT_ERROR_FORMS:
            raise ValueError(f"movingcam joint_error must be one of {JOINT_ERROR_FORMS}, got {self.joint_error!r}")

    @property
    def weights(self) -> np.ndarray:
        return np.array([self.joint_angle_weight, self.joint_velocity_weight, self.orientation_weight, self.contact_weight, self.torque_weight])

    @property
    def scales(self) -> np.ndarray:
        return np.array([self.joint_angle_scale, self.joint_velocity_scale, self.orientation_scale, self.contact_scale, self.torque_scale])

    @property
    def max_reward(self) -> float:
        return float(self.weights.sum())


class MovingcamReward:
    """`batch(...)` -> rewards (B,), terms into (B, 5); keeps each row's joint-angle error
    (`pose_error`, rad^2 summed) and orientation gap (`orientation_gap`, rad) for the
    termination rules."""

    def __init__(self, config: MovingcamRewardConfig, batch: int, num_contacts: int, num_actuators: int, num_joint_velocities: int):
        self.config = config
        self._weights = config.weights
        self._scales = -config.scales
        if config.joint_error == "mean":  # the exponent's error is the mean over joints (the sums stay in `errors`)
            self._scales[0] /= 12
            self._scales[1] /= num_joint_velocities
        b = batch
        self._dot = np.zeros((b, 8))
        self._hinge = np.zeros((b, 4))
        self._hinge_sum = np.zeros(b)
        self._vel = np.zeros((b, num_joint_velocities))
        self._contact = np.zeros((b, num_contacts), dtype=bool)
        self._torque = np.zeros((b, num_actuators))
        self.errors = np.zeros((b, NUM_TERMS))
        self.pose_error = self.errors[:, 0]
        self.orientation_gap = np.zeros(b)
        self._rewards = np.zeros(b)

    def batch(self, sim: RewardFeatures, ref: RewardFeatures, tilt: np.ndarray, hint: np.ndarray, hint_weight: np.ndarray,
              sim_contacts: np.ndarray, ref_contacts: np.ndarray, torque: np.ndarray, terms: np.ndarray) -> np.ndarray:
        """sim / ref reward features (B rows); tilt, hint, hint_weight (B,); contacts (B, E) bool
        (simulated) and 0/1 (flags); torque (B, nu) over the limits."""
        err, dot, hinge = self.errors, self._dot, self._hinge
        # E_q: ball joints (quaternions 1..8; 0 is the root) by 2 acos|<q*, q>|, hinges by gap.
        np.vecdot(sim.quats[:, 1:], ref.quats[:, 1:], out=dot)
        np.abs(dot, out=dot)
        np.minimum(dot, 1.0, out=dot)
        np.arccos(dot, out=dot)
        dot *= 2.0
        np.vecdot(dot, dot, out=err[:, 0])
        np.subtract(sim.hinges, ref.hinges, out=hinge)
        np.vecdot(hinge, hinge, out=self._hinge_sum)
        err[:, 0] += self._hinge_sum
        # E_v: qvel[6:], the joints' coordinates (ang_vel is qvel[3:]).
        np.subtract(sim.ang_vel[:, 3:], ref.ang_vel[:, 3:], out=self._vel)
        np.vecdot(self._vel, self._vel, out=err[:, 1])
        # E_ori: (|hint| - tilt)^2 where the hint is trusted.
        gap = self.orientation_gap
        np.abs(hint, out=gap)
        gap -= tilt
        np.abs(gap, out=gap)
        gap *= hint_weight
        np.square(gap, out=err[:, 2])
        # E_c: XOR of simulated contacts and flags.
        np.not_equal(sim_contacts, ref_contacts > 0.5, out=self._contact)
        np.sum(self._contact, axis=1, out=err[:, 3])
        np.vecdot(torque, torque, out=err[:, 4])
        np.multiply(err, self._scales, out=terms)
        np.exp(terms, out=terms)
        return np.matmul(terms, self._weights, out=self._rewards)
