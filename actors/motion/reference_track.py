"""A reference motion tabulated at the control rate, ready for O(1) lookups per step.

Episodes start on the control-step grid (k0 * dt), so the reference at every step of every
episode is a row of this table. Each row holds the reference's qpos / qvel (to start an
episode on it), its PD targets (the actuator lengths of the reference pose, what residual
actions add to) and the reward's kinematic features, computed once with MuJoCo itself on a
scratch MjData, so the reward compares like with like. Start velocities lose the clip's one-row
spikes (`actors/motion/start_velocity_filter.py`, a median over `start_velocity_median_rows`), then
are made ballistic in a flight (`actors/motion/ballistic_flight.py`) unless `flight_starts` is "reference";
the reward's features and `reference_qvel` (playback, measurements) keep the reference's own.
"""
from __future__ import annotations

import math

import mujoco
import numpy as np

from actors.character.features import FeatureExtractor, RewardFeatures, pose_obs_width, update_kinematics
from actors.character.humanoid3d import Humanoid
from actors.motion.ballistic_flight import FlightReport, ballistic_start_velocities
from actors.motion.reference_motion import ReferenceMotion
from actors.motion.start_velocity_filter import MEDIAN_ROWS, median_start_velocities
from actors.character.state import StateLayout

FLIGHT_STARTS = ("ballistic", "reference")


class ReferenceTrack:
    def __init__(self, motion: ReferenceMotion, humanoid: Humanoid, control_dt: float, horizon_s: float,
                 flight_starts: str = "ballistic", start_velocity_median_rows: int = MEDIAN_ROWS):
        if flight_starts not in FLIGHT_STARTS:
            raise ValueError(f"flight_starts must be one of {FLIGHT_STARTS}, got {flight_starts!r}")
        self.motion = motion
        self.dt = control_dt
        # Start indices cover one pass of the clip; looped episodes then run `horizon` steps.
        self.start_steps = max(1, int(round(motion.duration / control_dt)))
        if motion.loop:
            self.horizon_steps = int(round(horizon_s / control_dt))
            rows = self.start_steps + self.horizon_steps + 1
        else:
            self.horizon_steps = self.start_steps
            rows = self.start_steps + 1
        times = np.minimum(np.arange(rows) * control_dt, math.inf if motion.loop else motion.duration)
        self.times = times
        self.phase = motion.phase(times)
        if not motion.loop:
            self.phase[-1] = 1.0
        layout = StateLayout(humanoid)
        model = humanoid.model
        self.qpos = np.zeros((rows, model.nq))
        self.qvel = np.zeros((rows, model.nv))
        scratch = mujoco.MjData(model)
        features = FeatureExtractor(humanoid)
        self.features = RewardFeatures.zeros(model.nv, rows, features.reward_shape)
        self.ctrl = np.zeros((rows, model.nu))
        # The reference's own pose as the policy observes a pose: root height, link positions
        # relative to the root in the heading frame (`actors/envs/reference_obs.py`).
        pose_width = pose_obs_width(humanoid.character)
        self.pose_obs = np.zeros((rows, pose_width))
        observation = np.zeros((1, features.obs_dim))
        poses = motion.sample(times)
        for k in range(rows):
            pose_k = type(poses)(*(getattr(poses, f)[k] for f in poses.__dataclass_fields__))
            layout.pose_to_qpos_qvel(pose_k, self.qpos[k], self.qvel[k])
            scratch.qpos[:] = self.qpos[k]
            scratch.qvel[:] = self.qvel[k]
            update_kinematics(model, scratch)
            mujoco.mj_transmission(model, scratch)  # actuator_length: the pose as PD targets
            self.ctrl[k] = scratch.actuator_length
            self.features.values[k] = features.reward_features_of(scratch).values[0]
            features.observations(self.phase[k], observation)  # the rows just captured
            self.pose_obs[k] = observation[0, :pose_width]
        self.reference_qvel = self.qvel.copy()  # the clip's own velocities; self.qvel: what episodes start with
        self.qvel = median_start_velocities(self.qvel, start_velocity_median_rows, self.start_steps if motion.loop else None)
        self.flights = FlightReport()
        if flight_starts == "ballistic":
            self.qvel, self.flights = ballistic_start_velocities(model, self.qpos, self.qvel, control_dt)
        self._rows = [self.features.slice(slice(k, k + 1)) for k in range(rows)]  # views, built once

    def reward_features(self, row: int) -> RewardFeatures:
        """Row `row` as a batch of one (a view)."""
        return self._rows[row]

    @property
    def com(self) -> np.ndarray:
        return self.features.com

    @property
    def end_effectors(self) -> np.ndarray:
        return self.features.end_effectors

    @property
    def rows(self) -> int:
        return len(self.times)

    def episode_steps(self, start: int) -> int:
        """Control steps an episode starting at row `start` may run (its maximum length)."""
        return self.horizon_steps if self.motion.loop else self.start_steps - start

    def start_index(self, phase: float) -> int:
        """The grid row nearest to a phase in [0, 1]; the clip's last frame is not a start."""
        return int(min(round(phase * self.start_steps), self.start_steps - (0 if self.motion.loop else 1)) % self.start_steps)
