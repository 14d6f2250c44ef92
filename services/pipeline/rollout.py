"""The episode a user sees first: the policy from the clip's first frame, for the clip's length.

`first_frame_rollout` resets the env at the clip's first frame with its full reference state
(FSI), acts deterministically (the policy's mean) and judges falls by the clip's strict rule
after every control step (`services.training.evaluation.strict_fall_detector`), as `sfv eval`
does. Unlike an evaluation episode it does not stop at a fall: the character is filmed and
recorded to the clip's end (a video that stops at the fall hides what came after), but the
normalised return stops counting there (the fall forfeits the rest, as in `sfv eval`). A
simulation that diverges ends the recording.

`body_kinematics` turns qpos rows into the points the report measures (the 12 joints the
reconstruction fits, the feet, the lowest point of the body) on a scratch `MjData`, so the
simulated and the reference motion are measured by the same code.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable

import mujoco
import numpy as np

from actors.envs.imitation_env import ImitationEnv
from actors.character.skeleton import LINK_NAMES
from actors.motion.reference_motion import ReferenceMotion
from services.pipeline.metrics import box_lowest_z
from services.reconstruction.keypoints import FIT_LINKS, NUM_JOINT_KEYPOINTS


@dataclass
class FirstFrameRollout:
    control_hz: float
    qpos: np.ndarray  # (T, nq) the simulation after reset and after every control step
    reference_qpos: np.ndarray  # (T, nq) the reference row each of those steps went towards
    reference_rows: np.ndarray  # (T,) rows of env.track
    clip_steps: int  # control steps the clip lasts (T - 1 unless the simulation diverged)
    fell_at_step: int | None  # first control step after which the strict rule saw a fall
    diverged: bool
    normalized_return: float  # strict: rewards until the fall over the most the clip could earn
    rewards: np.ndarray  # (T - 1,) the env's reward of each step
    residual_force: np.ndarray | None = None  # (T - 1,) |residual root force| / body weight per step; None: the env has none

    @property
    def frames(self) -> int:
        return len(self.qpos)

    @property
    def fell(self) -> bool:
        return self.fell_at_step is not None or self.diverged

    @property
    def fell_at_s(self) -> float | None:
        if self.fell_at_step is not None:
            return self.fell_at_step / self.control_hz
        return (self.frames - 1) / self.control_hz if self.diverged else None

    def upright(self) -> np.ndarray:
        """(T,) bool: frame k comes before the fall."""
        steps = np.arange(self.frames)
        return steps < (self.fell_at_step if self.fell_at_step is not None else self.frames + 1)


class WithoutWrench:
    """A policy trained with a residual root wrench (actors/envs/residual_force.py), played with
    its last six outputs at zero: the body alone, to say whether the controller needs the help."""

    def __init__(self, policy):
        self.policy = policy

    def mean(self, obs: np.ndarray) -> np.ndarray:
        inner = getattr(self.policy, "mean", None)
        action = np.array(inner(obs) if callable(inner) else self.policy.act(obs, deterministic=True)[0], dtype=np.float32)
        action[..., -6:] = 0.0
        return action


def first_frame_rollout(policy, env: ImitationEnv, on_step: Callable[[int, int], None] | None = None) -> FirstFrameRollout:
    """Play the policy from the clip's first frame for the clip's length (one pass for a looped
    clip); `on_step(done, total)` after every control step (a progress bar)."""
    from services.training.evaluation import strict_fall_detector

    detector = strict_fall_detector(env)
    saved = env.config
    env.config = dataclasses.replace(saved, early_termination=False)  # falls are judged here, strictly
    try:
        obs, _ = env.reset(seed=0, options={"init": "fsi"})
        limit = min(env.max_episode_steps, env.track.start_steps)
        best = env.max_episode_return(limit)
        obs_row = np.empty((1, env.observation_space.shape[0]), np.float32)
        obs_row[0] = obs
        mean = getattr(policy, "mean", None)
        qpos = np.empty((limit + 1, env.model.nq))
        rows = np.empty(limit + 1, np.int64)
        rewards = np.zeros(limit)
        residual = env.core.residual  # a residual root wrench (actors/envs/residual_force.py), or None
        help_used = np.zeros(limit) if residual is not None else None
        qpos[0], rows[0] = env.data.qpos, env.row
        count, total, fell_at, diverged = 1, 0.0, None, False
        for step in range(1, limit + 1):
            action = mean(obs_row) if callable(mean) else policy.act(obs_row, deterministic=True)[0]
            obs, reward, terminated, _, _ = env.step(np.asarray(action)[0])
            if terminated or not np.isfinite(env.data.qpos).all():  # early termination is off: a divergence
                diverged = True
                break
            qpos[count], rows[count] = env.data.qpos, env.row
            rewards[step - 1] = reward
            if help_used is not None:
                help_used[step - 1] = residual.force_fraction[0]
            count += 1
            if fell_at is None:
                if detector(env.data):
                    fell_at = step
                    total += 0.0 if env.config.zero_reward_on_fall else reward
                else:
                    total += reward
            obs_row[0] = obs
            if on_step is not None:
                on_step(step, limit)
    finally:
        env.config = saved
    return FirstFrameRollout(float(env.config.control_hz), qpos[:count].copy(), env.track.qpos[rows[:count]].copy(),
                             rows[:count].copy(), limit, fell_at, diverged, total / best, rewards[:count - 1].copy(),
                             None if help_used is None else help_used[:count - 1].copy())


@dataclass
class BodyPoints:
    joints: np.ndarray  # (T, 12, 3) the reconstruction's 12 joint keypoints (link origins), world, m
    feet: np.ndarray  # (T, 2, 3) centres of the right and left foot boxes
    foot_heights: np.ndarray  # (T, 2) lowest point of each foot above the floor
    lowest: np.ndarray  # (T,) lowest point of the whole body above the floor


def _geom_lowest_z(model: mujoco.MjModel, data: mujoco.MjData, geoms: np.ndarray) -> np.ndarray:
    """Lowest z of each geom in `geoms` at data's kinematics (boxes, spheres, capsules, cylinders;
    other types by their bounding sphere)."""
    out = np.empty(len(geoms))
    for i, g in enumerate(geoms):
        centre, rotation, size = data.geom_xpos[g], data.geom_xmat[g].reshape(3, 3), model.geom_size[g]
        kind = model.geom_type[g]
        axis_z = abs(rotation[2, 2])
        if kind == mujoco.mjtGeom.mjGEOM_BOX:
            out[i] = box_lowest_z(centre, rotation, size)
        elif kind == mujoco.mjtGeom.mjGEOM_SPHERE:
            out[i] = centre[2] - size[0]
        elif kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
            out[i] = centre[2] - axis_z * size[1] - size[0]
        elif kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
            out[i] = centre[2] - axis_z * size[1] - size[0] * np.sqrt(max(0.0, 1.0 - axis_z * axis_z))
        else:
            out[i] = centre[2] - model.geom_rbound[g]
    return out


def body_kinematics(humanoid, qpos: np.ndarray, floor_z: float = 0.0) -> BodyPoints:
    """The measured points of every qpos row (a scratch MjData of the humanoid's model)."""
    model = humanoid.model
    data = mujoco.MjData(model)
    joint_bodies = humanoid.body_ids[FIT_LINKS[:NUM_JOINT_KEYPOINTS]]
    foot_bodies = [humanoid.body_ids[LINK_NAMES.index(name)] for name in ("right_ankle", "left_ankle")]
    foot_geoms = np.array([model.body_geomadr[b] for b in foot_bodies])
    body_set = set(int(b) for b in humanoid.body_ids)
    body_geoms = np.array([g for g in range(model.ngeom) if int(model.geom_bodyid[g]) in body_set])
    rows = len(qpos)
    joints, feet = np.empty((rows, len(joint_bodies), 3)), np.empty((rows, 2, 3))
    foot_heights, lowest = np.empty((rows, 2)), np.empty(rows)
    foot_slots = np.array([int(np.flatnonzero(body_geoms == g)[0]) for g in foot_geoms])
    for k in range(rows):
        data.qpos[:] = qpos[k]
        mujoco.mj_kinematics(model, data)
        joints[k] = data.xpos[joint_bodies]
        feet[k] = data.geom_xpos[foot_geoms]
        heights = _geom_lowest_z(model, data, body_geoms) - floor_z
        foot_heights[k] = heights[foot_slots]
        lowest[k] = heights.min()
    return BodyPoints(joints, feet, foot_heights, lowest)


def simulated_motion(rollout: FirstFrameRollout, env: ImitationEnv, name: str, extras: dict | None = None) -> ReferenceMotion:
    """The rollout as a motion file `sfv train --motion` takes (one frame per control step)."""
    from actors.character.skeleton import NUM_JOINTS

    frames = rollout.frames
    joint_rot = np.empty((frames, NUM_JOINTS, 4))
    for k in range(frames):
        env.layout.joint_quats_from_qpos(rollout.qpos[k], joint_rot[k])
    times = np.arange(frames) / rollout.control_hz
    return ReferenceMotion(name, times, rollout.qpos[:, 0:3].copy(), rollout.qpos[:, 3:7].copy(), joint_rot, loop=False,
                           extras=dict(extras or {}))
