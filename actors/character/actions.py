"""From a policy action to the PD targets of a character's position actuators (28 for humanoid3d).

Actions are normalised: the policy's output lives in [-1, 1] per component (the env clips).
Layout: the character's spherical joints first, then its revolute joints, each group in
joint order (`Character.joint_names` filtered), the same order as its actuators (humanoid3d:
8 ball joints and 4 hinges, `humanoid.py`).
- "exp_map" (28-D, the default): per spherical joint the rotation vector directly, per
  revolute an angle. DeepMimic's current code and MimicKit use it.
- "axis_angle" (SFV's 36-D): per spherical joint (angle, axis x, y, z), the angle scaled by
  pi, the axis normalised; per revolute joint one angle. The target is the rotation vector
  angle * axis, which is what a MuJoCo ball-joint actuator measures. It has a dead point at
  zero: (angle, axis) and (-angle, -axis) are the same target, so around a zero mean the
  expected gradient on the 8 ball joints cancels and each step's noise throws the target in
  a random 3-D direction (DeepMimic's 2018 code offset the default axis to escape it).
Targets are absolute (+-1 reaches the farther limit of each axis) or, with `residual_scale`,
residual: reference target + residual_scale (rad) * factor * action, the dynamic-camera
paper's eq. 1 (the zero action then tracks the reference instead of straightening every
joint); `residual_factors` (nu,) widens or narrows each joint's range (a character with soft
motors needs more radians for the same torque: `Character.residual_scale_factors`).
Each target is then clipped to the joint's per-axis limits (Z-up axes).
"""
from __future__ import annotations

import numpy as np

from actors.character.humanoid3d import HUMANOID3D

ACTION_PARAMETERISATIONS = ("axis_angle", "exp_map")


class ActionMapper:
    def __init__(self, parameterisation: str = "exp_map", residual_scale: float | None = None, character=HUMANOID3D,
                 residual_factors: np.ndarray | None = None):
        if parameterisation not in ACTION_PARAMETERISATIONS:
            raise ValueError(f"action parameterisation must be one of {ACTION_PARAMETERISATIONS}, got {parameterisation!r}")
        if residual_scale is not None and (parameterisation != "exp_map" or not residual_scale > 0):
            raise ValueError(f"residual targets need exp_map actions and a positive scale, got {parameterisation!r}, {residual_scale!r}")
        self.parameterisation = parameterisation
        self.residual_scale = residual_scale
        self.num_spherical = int(character.joint_is_spherical.sum())
        self.num_revolute = len(character.joint_names) - self.num_spherical
        self.sph_ctrl = 3 * self.num_spherical  # controls of spherical joints come first
        limits = character.actuator_limits  # (nu, 2)
        self.lower, self.upper = limits[:, 0].copy(), limits[:, 1].copy()
        self.scale = np.maximum(np.abs(self.lower), np.abs(self.upper))
        self.width = 4 if parameterisation == "axis_angle" else 3
        self.sph_width = self.width * self.num_spherical
        self.action_dim = self.sph_width + self.num_revolute
        assert self.sph_ctrl + self.num_revolute == character.nu
        if residual_scale is not None:
            factors = np.ones(character.nu) if residual_factors is None else np.asarray(residual_factors, dtype=np.float64)
            if factors.shape != (character.nu,) or not np.all(factors > 0):
                raise ValueError(f"residual factors must be {character.nu} positive numbers, got shape {factors.shape}")
            self.scale = residual_scale * factors
        self._sph_scale, self._rev_scale = self.scale[:self.sph_ctrl].copy(), self.scale[self.sph_ctrl:].copy()
        self._targets = np.zeros(character.nu)
        self._scratch: tuple = (0,)  # (rows, clipped actions, their views, angles)
        self._out_views: tuple = (None,)  # (out, its spherical, revolute and exp-map views)

    @property
    def residual(self) -> bool:
        return self.residual_scale is not None

    def targets(self, action: np.ndarray, out: np.ndarray | None = None, base: np.ndarray | None = None) -> np.ndarray:
        """PD targets (nu,) for one action; writes into `out` (e.g. MjData.ctrl) if given;
        `base` (nu,) is the reference target residual actions add to."""
        targets = self._targets if out is None else out
        self.targets_batch(np.asarray(action).reshape(1, -1), targets.reshape(1, -1), None if base is None else base.reshape(1, -1))
        return targets

    def _views(self, b: int, out: np.ndarray) -> tuple:
        """Scratch for b rows and views into `out`, built once (slicing and reshaping cost
        as much as the arithmetic on these few numbers)."""
        balls, ctrl = self.num_spherical, self.sph_ctrl
        if self._scratch[0] != b:
            clipped = np.zeros((b, self.action_dim))
            block = clipped[:, : self.sph_width].reshape(b, balls, self.width)
            angle = np.zeros((b, balls))
            self._scratch = (b, clipped, block[..., 0], block[..., 1:], clipped[:, :ctrl], clipped[:, self.sph_width:],
                             angle, angle[..., None])
        if self._out_views[0] is not out:
            self._out_views = (out, out[:, :ctrl].reshape(b, balls, 3), out[:, :ctrl], out[:, ctrl:])
        return self._scratch + self._out_views[1:]

    def targets_batch(self, actions: np.ndarray, out: np.ndarray, base: np.ndarray | None = None) -> np.ndarray:
        """PD targets (B, nu) for a batch of actions (B, action_dim), into `out`; residual
        actions add to `base` (B, nu), each env's reference targets.

        Plain ufunc calls with `out=` into fixed buffers: this runs every control step."""
        _, a, first, axis, exp_part, revolute, angle, angle_col, sph, out_sph, out_rev = self._views(actions.shape[0], out)
        np.minimum(actions, 1.0, out=a)
        np.maximum(a, -1.0, out=a)
        if self.parameterisation == "axis_angle":
            np.sqrt(np.vecdot(axis, axis, out=angle), out=angle)
            np.maximum(angle, 1e-6, out=angle)
            np.divide(first, angle, out=angle)
            angle *= np.pi
            np.multiply(axis, angle_col, out=sph)
        else:
            np.multiply(exp_part, self._sph_scale, out=out_sph)
        np.multiply(revolute, self._rev_scale, out=out_rev)
        if self.residual_scale is not None:
            if base is None:
                raise ValueError("residual actions need the reference targets (base)")
            out += base
        np.minimum(out, self.upper, out=out)
        np.maximum(out, self.lower, out=out)
        return out

    def action_for_targets(self, targets: np.ndarray, base: np.ndarray | None = None) -> np.ndarray:
        """An action whose targets are `targets` (inverse map, within limits); for tests and
        for driving the character with the reference pose. Residual actions are relative
        to `base` (zero when not given)."""
        action = np.zeros(self.action_dim)
        if self.residual_scale is not None and base is not None:
            targets = np.asarray(targets, dtype=np.float64) - base
        rv = np.asarray(targets[:self.sph_ctrl], dtype=np.float64).reshape(self.num_spherical, 3)
        if self.parameterisation == "axis_angle":
            angle = np.linalg.norm(rv, axis=1)
            axis = np.where(angle[:, None] > 1e-9, rv / np.maximum(angle, 1e-9)[:, None], np.array([1.0, 0, 0]))
            block = action[: self.sph_width].reshape(self.num_spherical, 4)
            block[:, 0] = angle / np.pi
            block[:, 1:] = axis
        else:
            action[:self.sph_ctrl] = rv.ravel() / self.scale[:self.sph_ctrl]
        action[self.sph_width:] = targets[self.sph_ctrl:] / self.scale[self.sph_ctrl:]
        return action
