"""From a policy action to the PD targets of MuJoCo's 28 position actuators.

Actions are normalised: the policy's output lives in [-1, 1] per component (the env clips).
Layout: the 8 spherical joints first, then the 4 revolute joints, each group in skeleton
order (`skeleton.JOINT_NAMES` filtered), the same order as the actuators in `humanoid.py`.
- "axis_angle" (SFV's 36-D, the default): per spherical joint (angle, axis x, y, z), the angle
  scaled by pi, the axis normalised; per revolute joint one angle. The target is the
  rotation vector angle * axis, which is what a MuJoCo ball-joint actuator measures.
- "exp_map" (28-D): per spherical joint the rotation vector directly, per revolute an angle.
Each target is then clipped to the joint's per-axis limits (Z-up axes). Revolute angles and
exp-map components are scaled so that +-1 reaches the farther limit of each axis.
"""
from __future__ import annotations

import numpy as np

from actors.skeleton import JOINT_LINKS, LINKS, NUM_ACTUATED_DOF, joint_limits_zup

ACTION_PARAMETERISATIONS = ("axis_angle", "exp_map")
SPHERICAL_LINKS = [i for i in JOINT_LINKS if LINKS[i].joint == "spherical"]
REVOLUTE_LINKS = [i for i in JOINT_LINKS if LINKS[i].joint == "revolute"]
NUM_SPHERICAL, NUM_REVOLUTE = len(SPHERICAL_LINKS), len(REVOLUTE_LINKS)
SPH_CTRL = 3 * NUM_SPHERICAL  # 24: controls of spherical joints come first


class ActionMapper:
    def __init__(self, parameterisation: str = "axis_angle"):
        if parameterisation not in ACTION_PARAMETERISATIONS:
            raise ValueError(f"action parameterisation must be one of {ACTION_PARAMETERISATIONS}, got {parameterisation!r}")
        self.parameterisation = parameterisation
        limits = np.concatenate([joint_limits_zup(LINKS[i]) for i in SPHERICAL_LINKS + REVOLUTE_LINKS])  # (28, 2)
        self.lower, self.upper = limits[:, 0].copy(), limits[:, 1].copy()
        self.scale = np.maximum(np.abs(self.lower), np.abs(self.upper))
        self.width = 4 if parameterisation == "axis_angle" else 3
        self.sph_width = self.width * NUM_SPHERICAL
        self.action_dim = self.sph_width + NUM_REVOLUTE
        assert SPH_CTRL + NUM_REVOLUTE == NUM_ACTUATED_DOF
        self._sph_scale, self._rev_scale = self.scale[:SPH_CTRL].copy(), self.scale[SPH_CTRL:].copy()
        self._targets = np.zeros(NUM_ACTUATED_DOF)
        self._scratch: tuple = (0,)  # (rows, clipped actions, their views, angles)
        self._out_views: tuple = (None,)  # (out, its spherical, revolute and exp-map views)

    def targets(self, action: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """PD targets (28,) for one action; writes into `out` (e.g. MjData.ctrl) if given."""
        targets = self._targets if out is None else out
        self.targets_batch(np.asarray(action).reshape(1, -1), targets.reshape(1, -1))
        return targets

    def _views(self, b: int, out: np.ndarray) -> tuple:
        """Scratch for b rows and views into `out`, built once (slicing and reshaping cost
        as much as the arithmetic on these few numbers)."""
        if self._scratch[0] != b:
            clipped = np.zeros((b, self.action_dim))
            block = clipped[:, : self.sph_width].reshape(b, NUM_SPHERICAL, self.width)
            angle = np.zeros((b, NUM_SPHERICAL))
            self._scratch = (b, clipped, block[..., 0], block[..., 1:], clipped[:, : SPH_CTRL], clipped[:, self.sph_width:],
                             angle, angle[..., None])
        if self._out_views[0] is not out:
            self._out_views = (out, out[:, :SPH_CTRL].reshape(b, NUM_SPHERICAL, 3), out[:, :SPH_CTRL], out[:, SPH_CTRL:])
        return self._scratch + self._out_views[1:]

    def targets_batch(self, actions: np.ndarray, out: np.ndarray) -> np.ndarray:
        """PD targets (B, 28) for a batch of actions (B, action_dim), into `out`.

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
        np.minimum(out, self.upper, out=out)
        np.maximum(out, self.lower, out=out)
        return out

    def action_for_targets(self, targets: np.ndarray) -> np.ndarray:
        """An action whose targets are `targets` (inverse map, within limits); for tests and
        for driving the character with the reference pose."""
        action = np.zeros(self.action_dim)
        rv = np.asarray(targets[:SPH_CTRL], dtype=np.float64).reshape(NUM_SPHERICAL, 3)
        if self.parameterisation == "axis_angle":
            angle = np.linalg.norm(rv, axis=1)
            axis = np.where(angle[:, None] > 1e-9, rv / np.maximum(angle, 1e-9)[:, None], np.array([1.0, 0, 0]))
            block = action[: self.sph_width].reshape(NUM_SPHERICAL, 4)
            block[:, 0] = angle / np.pi
            block[:, 1:] = axis
        else:
            action[:SPH_CTRL] = rv.ravel() / self.scale[:SPH_CTRL]
        action[self.sph_width:] = targets[SPH_CTRL:] / self.scale[SPH_CTRL:]
        return action
