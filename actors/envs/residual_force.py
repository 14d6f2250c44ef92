"""A residual wrench on the root: the policy's help where a reconstructed motion asks more than
the body's joints can give (residual force control, Yuan & Kitani 2020; SimPoE, Yuan et al. 2021).

A video's reconstruction is fitted to the humanoid's skeleton but not to its mass distribution,
so a pose the person held (a one-leg balance with the arms out) can put the humanoid's centre of
mass beyond its stance foot. Tracked with joint torques alone, the controller must then leave the
reference to stay up: on the Pose2Sim balancing trial the simulated motion was 45 mm further from
the triangulated markers (PA-MPJPE) than the kinematic reference it tracked
(`bench/results/videos.json`). With `EnvConfig.residual_force` > 0 the action gains six numbers
in [-1, 1], a force and a torque in the root's own frame, applied at the root's centre of mass
(`MjData.xfrc_applied`) through the control step's substeps:

    force  = residual_force x m g x a[0:3]          (N; m the character's mass)
    torque = residual_force x m g x ARM_M x a[3:6]  (N m)

and the step's reward is multiplied by (1 - w) + w exp(-K ||a_wrench||^2), w = residual_force_weight:
the tracking reward is unchanged where no help is asked, so normalised returns stay comparable,
and help costs up to w of every step's reward (RFC's regulariser, there an added term). The
wrench is not a body's own effort: a controller that uses it is not physically self-sufficient,
and `sfv pipeline`'s report says how much it used (mean and max, fraction of body weight).
"""
from __future__ import annotations

import numpy as np

WRENCH_DIM = 6  # force xyz, torque xyz, in the root's frame
ARM_M = 0.5  # the torque's scale as a force at this lever: about the root-to-centre-of-mass reach of a leaning body
K = 2.0  # the regulariser's kernel on the squared normalised wrench: a = .3 on every axis keeps .34 of the help's share


class ResidualForce:
    """The wrench part of a batch of actions: scales, the world wrench per env, the reward factor."""

    def __init__(self, fraction: float, weight: float, mass_kg: float, root_body: int, num_envs: int,
                 strength: float = 1.0):
        if not fraction > 0:
            raise ValueError(f"residual force must be > 0 (a fraction of body weight), got {fraction}")
        if not 0.0 <= weight <= 1.0:
            raise ValueError(f"residual force weight must be in [0, 1], got {weight}")
        self.fraction = float(fraction)
        self.weight = float(weight)
        self.root_body = int(root_body)
        self.weight_n = float(mass_kg) * 9.81
        self._full_scale = np.array([fraction * self.weight_n] * 3 + [fraction * self.weight_n * ARM_M] * 3)
        self.scale = self._full_scale.copy()
        self.strength = 1.0
        self.set_strength(strength)
        self.local = np.zeros((num_envs, WRENCH_DIM))  # this step's wrench per env, root frame, N and N m
        self.force_fraction = np.zeros(num_envs)  # |force| / (m g) of this step, per env
        self._squares = np.zeros(num_envs)
        self._factor = np.zeros(num_envs)

    def set_strength(self, strength: float) -> None:
        """Scale the wrench's reach to `strength` x its full size (a help that decays over training,
        `TrainConfig.residual_force_final`); the action's meaning and its price are unchanged."""
        if not 0.0 <= strength <= 1.0:
            raise ValueError(f"residual force strength must be in [0, 1], got {strength}")
        self.strength = float(strength)
        np.multiply(self._full_scale, self.strength, out=self.scale)

    def take(self, actions: np.ndarray) -> None:
        """Read the wrench part (B, 6) of a batch of actions (clipped to [-1, 1])."""
        np.clip(actions, -1.0, 1.0, out=self.local)
        np.einsum("bi,bi->b", self.local, self.local, out=self._squares)
        self.local *= self.scale
        np.sqrt(np.einsum("bi,bi->b", self.local[:, :3], self.local[:, :3]), out=self.force_fraction)
        self.force_fraction /= self.weight_n

    def reward_factor(self) -> np.ndarray:
        """(B,) the step's reward multiplier: 1 with no wrench, 1 - weight at most help."""
        np.multiply(self._squares, -K, out=self._factor)
        np.exp(self._factor, out=self._factor)
        self._factor *= self.weight
        self._factor += 1.0 - self.weight
        return self._factor

    def push(self, i: int, data) -> None:
        """Put env i's wrench of this step on its root (the simulator's loop calls this per env)."""
        self.apply(data, self.root_body, self.local[i])

    @staticmethod
    def apply(data, body: int, wrench: np.ndarray) -> None:
        """Put one env's root-frame wrench (6,) on `body` in world coordinates (MjData.xfrc_applied)."""
        rotation = data.xmat[body].reshape(3, 3)
        applied = data.xfrc_applied[body]
        np.dot(rotation, wrench[:3], out=applied[:3])
        np.dot(rotation, wrench[3:], out=applied[3:])
