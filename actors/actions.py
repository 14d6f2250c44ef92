"""From a policy action to the PD targets of MuJoCo's 28 position actuators.

Actions are normalised: the policy's output lives in [-1, 1] per component (the env clips).
- "axis_angle" (SFV's 36-D, the default): per spherical joint (angle, axis x, y, z), the angle
  scaled by `pi`, the axis normalised; per revolute joint one angle. The target is the
  rotation vector angle * axis, which is what a MuJoCo ball-joint actuator measures.
- "exp_map" (28-D): per spherical joint the rotation vector directly, per revolute an angle.
Each target is then clipped to the joint's per-axis limits (Z-up axes).
"""
from __future__ import annotations

import numpy as np

from actors.skeleton import JOINT_IS_SPHERICAL, JOINT_LINKS, LINKS, NUM_ACTUATED_DOF, joint_limits_zup

ACTION_PARAMETERISATIONS = ("axis_angle", "exp_map")


class ActionMapper:
    def __init__(self, parameterisation: str = "axis_angle"):
        if parameterisation not in ACTION_PARAMETERISATIONS:
            raise ValueError(f"action parameterisation must be one of {ACTION_PARAMETERISATIONS}, got {parameterisation!r}")
        self.parameterisation = parameterisation
        limits = np.concatenate([joint_limits_zup(LINKS[i]) for i in JOINT_LINKS])  # (28, 2)
        self.lower, self.upper = limits[:, 0].copy(), limits[:, 1].copy()
        # A zero action is the neutral pose; +-1 reaches the farther limit of each axis.
        self.scale = np.maximum(np.abs(self.lower), np.abs(self.upper))
        n_sph = int(JOINT_IS_SPHERICAL.sum())
        n_rev = len(JOINT_IS_SPHERICAL) - n_sph
        # Where each joint's numbers sit in the action vector and in the actuator vector.
        act_ptr, ctrl_ptr = 0, 0
        sph_act, sph_ctrl, rev_act, rev_ctrl = [], [], [], []
        width = 4 if parameterisation == "axis_angle" else 3
        for spherical in JOINT_IS_SPHERICAL:
            if spherical:
                sph_act.append(np.arange(act_ptr, act_ptr + width))
                sph_ctrl.append(np.arange(ctrl_ptr, ctrl_ptr + 3))
                act_ptr, ctrl_ptr = act_ptr + width, ctrl_ptr + 3
            else:
                rev_act.append(act_ptr)
                rev_ctrl.append(ctrl_ptr)
                act_ptr, ctrl_ptr = act_ptr + 1, ctrl_ptr + 1
        self.action_dim = act_ptr
        assert ctrl_ptr == NUM_ACTUATED_DOF and len(sph_act) == n_sph and len(rev_act) == n_rev
        self.sph_act, self.sph_ctrl = np.array(sph_act), np.array(sph_ctrl)
        self.rev_act, self.rev_ctrl = np.array(rev_act), np.array(rev_ctrl)
        self._clipped = np.zeros(self.action_dim)
        self._targets = np.zeros(NUM_ACTUATED_DOF)

    def targets(self, action: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """PD targets (28,) for one action; writes into `out` (e.g. MjData.ctrl) if given."""
        a = np.clip(action, -1.0, 1.0, out=self._clipped)
        t = self._targets
        if self.parameterisation == "axis_angle":
            block = a[self.sph_act]  # (8, 4): angle, axis
            axis = block[:, 1:]
            norm = np.sqrt(np.einsum("ij,ij->i", axis, axis))
            angle = block[:, 0] * np.pi / np.maximum(norm, 1e-6)
            t[self.sph_ctrl] = axis * angle[:, None]
        else:
            t[self.sph_ctrl] = a[self.sph_act] * self.scale[self.sph_ctrl]
        t[self.rev_ctrl] = a[self.rev_act] * self.scale[self.rev_ctrl]
        np.clip(t, self.lower, self.upper, out=t)
        if out is not None:
            out[:] = t
        return t

    def action_for_targets(self, targets: np.ndarray) -> np.ndarray:
        """An action whose targets are `targets` (inverse map, within limits); for tests and
        for driving the character with the reference pose (`hold`-style controllers)."""
        action = np.zeros(self.action_dim)
        if self.parameterisation == "axis_angle":
            rv = targets[self.sph_ctrl]
            angle = np.linalg.norm(rv, axis=1)
            axis = np.where(angle[:, None] > 1e-9, rv / np.maximum(angle, 1e-9)[:, None], np.array([1.0, 0, 0]))
            action[self.sph_act[:, 0]] = angle / np.pi
            action[self.sph_act[:, 1:]] = axis
        else:
            action[self.sph_act] = targets[self.sph_ctrl] / self.scale[self.sph_ctrl]
        action[self.rev_act] = targets[self.rev_ctrl] / self.scale[self.rev_ctrl]
        return action
