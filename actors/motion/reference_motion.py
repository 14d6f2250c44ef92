"""`ReferenceMotion`: a clip the character imitates, sampled at any time.

A clip is a root trajectory plus the local rotation of each of the 12 joints (quaternions,
revolute joints as rotations about the hinge axis), in the Z-up frame of `skeleton.py`; or,
with `character` a robot's name, of each of the robot's hinges (a robot motion file read by
`actors/motion/robot_reference.py`), so the track, the state layout and the reward sample
either body's reference the same way.
Frames may be unevenly spaced (`frame_times`). Poses between frames are slerped; velocities
are central differences at the frames, linearly interpolated. A looped clip repeats with its
horizontal root displacement accumulated per cycle (the "cyclic root offset"), so a walk
keeps walking forward instead of jumping back to the start.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from actors.character import quaternion as qn
from actors.character.kinematics import forward_kinematics
from learner.errors import SfvError


class MotionFormatError(SfvError, ValueError):
    """A motion file is malformed; the message names the file and the fault (any format)."""

@dataclass
class MotionPose:
    """A pose and its velocities at one instant (root linear velocity in world frame,
    root angular velocity in the root frame, joint angular velocities in each child frame:
    the conventions of MuJoCo's free and ball joints)."""

    root_pos: np.ndarray
    root_rot: np.ndarray
    joint_rot: np.ndarray
    root_lin_vel: np.ndarray
    root_ang_vel: np.ndarray
    joint_ang_vel: np.ndarray


@dataclass
class ReferenceMotion:
    name: str
    frame_times: np.ndarray  # (T,) seconds, strictly increasing, starting at 0
    root_pos: np.ndarray  # (T, 3) metres, Z up
    root_rot: np.ndarray  # (T, 4) unit quaternions (w, x, y, z)
    joint_rot: np.ndarray  # (T, 12, 4) unit quaternions, parent-local
    loop: bool = False
    extras: dict = field(default_factory=dict)  # arrays carried along in the file (keypoints, ...)
    source: str | None = field(default=None, compare=False)  # the file it was loaded from (for error messages)
    # The body whose pose space the joints are in: humanoid3d's 12 joints, or a robot's hinges
    # as rotations about their axes (`actors/motion/robot_reference.py`).
    character: str = "humanoid3d"

    def __post_init__(self):
        self.frame_times = np.asarray(self.frame_times, dtype=np.float64)
        self._compute_frame_velocities()

    # ----------------------------------------------------------------- properties
    @property
    def num_frames(self) -> int:
        return len(self.frame_times)

    @property
    def duration(self) -> float:
        return float(self.frame_times[-1])

    @property
    def fps(self) -> float:
        return float((self.num_frames - 1) / self.duration)

    @property
    def cycle_offset(self) -> np.ndarray:
        """Horizontal root displacement over one pass of the clip (zero unless looped)."""
        offset = self.root_pos[-1] - self.root_pos[0]
        offset[2] = 0.0
        return offset if self.loop else np.zeros(3)

    def root_front(self, frame: int = 0) -> np.ndarray:
        """World direction of the root's +x (its front) at a frame (a scene's axes read it)."""
        return qn.quat_rotate(self.root_rot[frame], np.array([1.0, 0.0, 0.0]))

    def link_positions(self, frame: int = 0) -> np.ndarray:
        """(links, 3) world positions of the humanoid's links at a frame (forward kinematics)."""
        if self.character != "humanoid3d":
            raise MotionFormatError(f"{self.source or self.name}: link positions are the humanoid3d's; this is a {self.character} motion")
        links, _ = forward_kinematics(self.root_pos[frame], self.root_rot[frame], self.joint_rot[frame])
        return links

    # ------------------------------------------------------------------- sampling
    def _locate(self, t: np.ndarray):
        """Cycle count, frame index i and blend weight w such that time t lies in [i, i+1]."""
        t = np.asarray(t, dtype=np.float64)
        if self.loop:
            cycles = np.floor(t / self.duration)
            local = t - cycles * self.duration
        else:
            cycles = np.zeros_like(t)
            local = np.clip(t, 0.0, self.duration)
        i = np.clip(np.searchsorted(self.frame_times, local, side="right") - 1, 0, self.num_frames - 2)
        w = (local - self.frame_times[i]) / (self.frame_times[i + 1] - self.frame_times[i])
        return cycles, i, np.clip(w, 0.0, 1.0)

    def sample(self, t) -> MotionPose:
        """Pose and velocities at time(s) t (scalar or array; leading dims follow t)."""
        cycles, i, w = self._locate(t)
        wv = w[..., None]
        root_pos = (1 - wv) * self.root_pos[i] + wv * self.root_pos[i + 1] + cycles[..., None] * self.cycle_offset
        root_rot = qn.quat_slerp(self.root_rot[i], self.root_rot[i + 1], w)
        joint_rot = qn.quat_slerp(self.joint_rot[i], self.joint_rot[i + 1], w[..., None])
        lerp = lambda a: (1 - w.reshape(w.shape + (1,) * (a.ndim - 1))) * a[i] + w.reshape(w.shape + (1,) * (a.ndim - 1)) * a[i + 1]
        return MotionPose(root_pos, root_rot, joint_rot, lerp(self._root_lin_vel), lerp(self._root_ang_vel), lerp(self._joint_ang_vel))

    def phase(self, t) -> np.ndarray:
        """Phase in [0, 1]: 0 at the clip's start, 1 at its end (wrapping for loops)."""
        t = np.asarray(t, dtype=np.float64)
        if self.loop:
            return np.mod(t, self.duration) / self.duration
        return np.clip(t / self.duration, 0.0, 1.0)

    # ----------------------------------------------------------------- velocities
    def _compute_frame_velocities(self):
        """Velocity at each frame: the time-weighted mean of the differences on either side.

        The pose between frames i and i+1 moves at the forward difference d_i; interpolating
        forward differences as frame velocities would lead the pose by half a frame (31 ms at
        the backflip's 16 Hz), so a frame's velocity is the mean of d_{i-1} and d_i (each weighted
        by the other side's interval: the central difference, exact for a parabola). Backflip, defaults, 1 worker: the forward
        differences reached at 3 M samples what central ones reached at 2 M
        (bench/results/acrobatics/long_runs.json). A loop's ends use the differences across
        the wrap; a clip's ends otherwise their one-sided difference.
        """
        dt = np.diff(self.frame_times)
        lin = np.diff(self.root_pos, axis=0) / dt[:, None]
        # Angular velocity in the child frame: log(q_t^-1 q_{t+1}) / dt, as MuJoCo's ball joints.
        root_ang = qn.quat_to_axis_angle(qn.quat_mul(qn.quat_conj(self.root_rot[:-1]), self.root_rot[1:])) / dt[:, None]
        joint_ang = qn.quat_to_axis_angle(qn.quat_mul(qn.quat_conj(self.joint_rot[:-1]), self.joint_rot[1:])) / dt[:, None, None]
        self._root_lin_vel = self._central(lin, dt)
        self._root_ang_vel = self._central(root_ang, dt)
        self._joint_ang_vel = self._central(joint_ang, dt)

    def _central(self, diffs: np.ndarray, dt: np.ndarray) -> np.ndarray:
        """(T, ...) frame velocities from the (T-1, ...) differences between frames."""
        if len(diffs) == 1:
            return np.concatenate((diffs, diffs))
        if self.loop:
            before, dt_before = np.concatenate((diffs[-1:], diffs)), np.concatenate((dt[-1:], dt))
            after, dt_after = np.concatenate((diffs, diffs[:1])), np.concatenate((dt, dt[:1]))
        else:
            before, dt_before = np.concatenate((diffs[:1], diffs)), np.concatenate((dt[:1], dt))
            after, dt_after = np.concatenate((diffs, diffs[-1:])), np.concatenate((dt, dt[-1:]))
        shape = (-1,) + (1,) * (diffs.ndim - 1)
        # Each side weighted by the other's interval: exact for a parabola on uneven steps.
        hb, ha = dt_before.reshape(shape), dt_after.reshape(shape)
        return (ha * before + hb * after) / (hb + ha)

    def summary(self) -> dict:
        return {
            "name": self.name,
            "frames": self.num_frames,
            "duration": round(self.duration, 6),
            "fps": round(self.fps, 6),
            "loop": self.loop,
            "joints": int(self.joint_rot.shape[1]),
        }
