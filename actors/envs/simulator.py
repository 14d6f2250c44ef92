"""The simulator seam under the env core: the physics of a batch of envs.

`MujocoSimulator` is today's backend, C MuJoCo over a list of `MjData` (one per env, each
with its model: a scene's boxes move per env, so each env may own a copy). `step` is the one
stepping loop every env shares (the imitation envs, batch of one or many, and the task env):
set each env's PD targets, advance its substeps, bring its kinematics up to date, flag a
divergence (MuJoCo resets the data itself when the simulation blows up and only counts a
warning), test the env's fall rule and hand the data to the feature captures. Everything the
envs read of the physics after that comes through the captures (`FeatureExtractor.capture`,
a mode's or a task's), so a batched backend (MuJoCo's batched rollouts, MJX or MuJoCo Warp on
a GPU) plugs in here by implementing `step`, `reset` and `forward` and writing the captured
arrays in one pass.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

import mujoco
import numpy as np

from actors.character.features import update_kinematics

_FIRST_BAD = int(mujoco.mjtWarning.mjWARN_BADQPOS)
assert (int(mujoco.mjtWarning.mjWARN_BADQVEL), int(mujoco.mjtWarning.mjWARN_BADQACC)) == (_FIRST_BAD + 1, _FIRST_BAD + 2)


def divergence_counters(data: mujoco.MjData) -> np.ndarray:
    """A view of MuJoCo's BADQPOS, BADQVEL and BADQACC warning counters (mj_resetData clears them)."""
    return data.warning.number[_FIRST_BAD:_FIRST_BAD + 3]


class MujocoSimulator:
    """C MuJoCo over a list of MjData: the batch's physics, stepped one env after the other."""

    def __init__(self, models: Sequence[mujoco.MjModel], datas: Sequence[mujoco.MjData], substeps: int):
        if len(models) != len(datas):
            raise ValueError(f"one model per data: {len(models)} models, {len(datas)} datas")
        self.models = list(models)
        self.datas = list(datas)
        self.substeps = substeps
        self.num_envs = len(self.datas)
        self._slots = [(m, d, divergence_counters(d)) for m, d in zip(self.models, self.datas)]

    def step(self, targets: np.ndarray, fell: np.ndarray, diverged: np.ndarray,
             fall: Callable[[mujoco.MjData], bool] | None = None, captures: Sequence[Callable] = (),
             residual=None) -> None:
        """Advance every env one control step towards its PD targets (B, nu); write each env's
        divergence and fall (`fall(data)`; no rule: never) and run `captures(i, data)`.
        `residual` (a `ResidualForce` holding this step's wrenches) pushes on each env's root."""
        substeps = self.substeps
        push = None if residual is None else residual.push
        for i, (model, data, warnings) in enumerate(self._slots):
            data.ctrl[:] = targets[i]
            if push is not None:
                push(i, data)
            mujoco.mj_step(model, data, nstep=substeps)
            update_kinematics(model, data)
            diverged[i] = bool(warnings[0] or warnings[1] or warnings[2])  # cheaper than .any() on 3 ints
            fell[i] = fall is not None and fall(data)
            for capture in captures:
                capture(i, data)

    def reset(self, i: int) -> mujoco.MjData:
        """Clear env i's state (mj_resetData) and return its data for the caller to fill."""
        mujoco.mj_resetData(self.models[i], self.datas[i])
        return self.datas[i]

    def forward(self, i: int) -> None:
        """Bring env i's kinematics up to its current qpos / qvel."""
        update_kinematics(self.models[i], self.datas[i])
