"""The observation of `observation_layout` recomputed from MuJoCo data and `reference_track` (package docstring)."""
from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np

from services.export.sim2sim.policy import Sim2SimError


def update_kinematics(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """Positions and body velocities of the current qpos / qvel (mj_step leaves them one step behind)."""
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    mujoco.mj_comVel(model, data)


# ---------------------------------------------------------------------- the observation
def _heading(xmat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(Rz(th), conj(q_h)) of a root rotation matrix (9,): th the yaw of its x axis."""
    theta = math.atan2(xmat[3], xmat[0])
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]), np.array([math.cos(theta / 2), 0.0, 0.0, -math.sin(theta / 2)])


def _turned(left: np.ndarray, quats: np.ndarray) -> np.ndarray:
    """left * q (Hamilton) for each row of `quats` (n, 4), w made non-negative."""
    a0, a1, a2, a3 = left
    b0, b1, b2, b3 = quats.T
    out = np.stack([a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3, a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
                    a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1, a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0], axis=1)
    return np.where(out[:, :1] < 0.0, -out, out)


class Observer:
    """The observation of `observation_layout` from MuJoCo data, the reference from `reference_track`."""

    def __init__(self, model: mujoco.MjModel, meta: dict, xml: Path | str = "the robot MJCF"):
        self.model = model
        self.bodies = []
        for name in meta["observation_links"]:
            body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
            if body < 0:
                raise Sim2SimError(f"{xml}: no body {name} (the policy's observation_links name it)")
            self.bodies.append(body)
        self.root = self.bodies[0]
        self.layout = [(b["name"], int(b["start"]), int(b["size"])) for b in meta["observation_layout"]]
        self.dim = sum(size for _, _, size in self.layout)
        reference, track = meta["observation_reference"], meta["reference_track"]
        self.root_steps = np.asarray(reference["root_steps"], dtype=np.int64)
        self.pose_steps = np.asarray(reference["pose_steps"], dtype=np.int64)
        self.qpos = np.asarray(track["qpos"], dtype=np.float64)
        self.phase = np.asarray(track["phase"], dtype=np.float64)
        self.last_row = len(self.phase) - 1
        self._scratch = mujoco.MjData(model)
        self._velocity = np.zeros(6)

    def observe(self, data: mujoco.MjData, row: int, offset: np.ndarray) -> np.ndarray:
        """The observation at reference row `row` of `data` (kinematics up to date), the root-sync `offset` (2,)."""
        yaw, conj = _heading(data.xmat[self.root])
        out = np.zeros(self.dim)
        for name, start, size in self.layout:
            out[start:start + size] = self._block(name, data, row, offset, yaw, conj)
        return out

    def _block(self, name: str, data, row: int, offset, yaw, conj) -> np.ndarray:
        bodies, root = self.bodies, data.xpos[self.root]
        if name == "root_height":
            return root[2:3]
        if name == "link_positions":
            return ((data.xpos[bodies] - root) @ yaw).ravel()
        if name == "link_rotations":
            return _turned(conj, data.xquat[bodies]).ravel()
        if name in ("link_linear_velocities", "link_angular_velocities"):
            return (self._velocities(data, name == "link_angular_velocities") @ yaw).ravel()
        rows = np.minimum(row + self.root_steps, self.last_row)
        if name == "reference_root_positions":
            positions = self.qpos[rows, 0:3].copy()
            positions[:, :2] += offset
            return ((positions - root) @ yaw).ravel()
        if name == "reference_root_rotations":
            return _turned(conj, self.qpos[rows, 3:7]).ravel()
        if name == "phase":
            return self.phase[min(row, self.last_row):][:1]
        return np.concatenate([self._reference_pose(min(row + k, self.last_row)) for k in self.pose_steps])  # reference_poses

    def _velocities(self, data, angular: bool) -> np.ndarray:
        """(links, 3) each body origin's world angular or linear velocity."""
        rows = []
        for body in self.bodies:
            mujoco.mj_objectVelocity(self.model, data, mujoco.mjtObj.mjOBJ_XBODY, body, self._velocity, 0)  # XBODY: at xpos, not the inertial frame
            rows.append(self._velocity[:3].copy() if angular else self._velocity[3:].copy())
        return np.array(rows)

    def _reference_pose(self, row: int) -> np.ndarray:
        """The reference pose of a row as the policy sees its own: root height, link positions in its heading frame."""
        scratch = self._scratch
        scratch.qpos[:] = self.qpos[row]
        mujoco.mj_kinematics(self.model, scratch)
        yaw, _ = _heading(scratch.xmat[self.root])
        root = scratch.xpos[self.root]
        return np.concatenate([root[2:3], ((scratch.xpos[self.bodies] - root) @ yaw).ravel()])
