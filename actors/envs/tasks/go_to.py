"""Go to a target at a requested speed and heading (Merel et al. 2019's go-to-target, with
the speed and heading instructions of this issue).

Per target: a position U(target_distance) metres away in a uniformly random direction, a
requested speed U(speed_range) and a requested heading (facing direction) = the direction to
the target + U(+-heading_spread). Reward per step, in [0, 1]:
    0.7 exp(-2 (v_toward - v_requested)^2) + 0.3 (1 + cos(yaw - heading_requested)) / 2
with v_toward the centre of mass's horizontal velocity along the direction to the target; a
target within `success_radius` adds `success_bonus` and a new target is drawn at once (as in
Merel et al.: the episode runs to its horizon, so reaching never cuts the reward short).
Task features (6, in the heading frame): target x, y, its distance, the requested speed and
the requested heading's cos, sin relative to the current one.
"""
from __future__ import annotations

import numpy as np

from actors.arenas.slope import task_floor
from actors.envs.tasks.geometry import polar, to_heading_frame, wrap_angle

SPEED_WEIGHT, HEADING_WEIGHT = 0.7, 0.3


class GoToTask:
    obs_dim = 6

    @staticmethod
    def arena_for(config):
        """The flat floor, or the slope of `--env.slope` (`actors/arenas/slope.py`)."""
        return task_floor(config.slope)

    def __init__(self, config, num_envs: int, model=None):
        self.config = config
        self.arena = self.arena_for(config)
        self.target = np.zeros((num_envs, 2))
        self._start = np.zeros((num_envs, 2))
        self.speed = np.ones(num_envs)
        self.heading = np.zeros(num_envs)

    def reset(self, i: int, root_xy: np.ndarray, yaw: float, rng: np.random.Generator, data=None) -> None:
        self._start[i] = root_xy
        self._draw(i, root_xy, rng)

    def first_direction(self, i: int) -> np.ndarray:
        """The unit xy direction from env i's start to its first target."""
        d = self.target[i] - self._start[i]
        return d / max(float(np.linalg.norm(d)), 1e-9)

    def _draw(self, i: int, root_xy: np.ndarray, rng: np.random.Generator) -> None:
        c = self.config
        offset = polar(rng, c.target_distance, 0.0, np.pi)
        self.target[i] = root_xy + offset
        self.speed[i] = rng.uniform(*c.speed_range)
        self.heading[i] = np.arctan2(offset[1], offset[0]) + rng.uniform(-c.heading_spread, c.heading_spread)

    def place(self, i: int, target_xy: np.ndarray, speed: float, heading: float) -> None:
        """Set env i's current target, requested speed and heading (the heatmap's fixed placements)."""
        self.target[i] = target_xy
        self.speed[i] = speed
        self.heading[i] = heading

    def capture(self, i: int, data) -> None:
        """Nothing of the scene to read: the target lives here."""

    def rewards(self, root_xy: np.ndarray, vel_xy: np.ndarray, yaw: np.ndarray, rng: np.random.Generator):
        """(rewards (B,), reached (B,) bool); reached targets are redrawn."""
        offset = self.target - root_xy
        distance = np.linalg.norm(offset, axis=1)
        toward = np.einsum("bi,bi->b", vel_xy, offset) / np.maximum(distance, 1e-6)
        rewards = SPEED_WEIGHT * np.exp(-2.0 * (toward - self.speed) ** 2)
        rewards += HEADING_WEIGHT * 0.5 * (1.0 + np.cos(yaw - self.heading))
        reached = distance < self.config.success_radius
        rewards[reached] += self.config.success_bonus
        for i in np.flatnonzero(reached):
            self._draw(i, root_xy[i], rng)
        return rewards, reached

    def features(self, root_xy: np.ndarray, vel_xy: np.ndarray, yaw: np.ndarray, out: np.ndarray) -> np.ndarray:
        rel = to_heading_frame(self.target - root_xy, yaw)
        out[:, 0:2] = rel
        out[:, 2] = np.linalg.norm(rel, axis=1)
        out[:, 3] = self.speed
        relative_heading = wrap_angle(self.heading - yaw)
        out[:, 4] = np.cos(relative_heading)
        out[:, 5] = np.sin(relative_heading)
        return out

    def marker(self, i: int) -> np.ndarray:
        """World position of env i's target (for the renderer)."""
        return np.array([self.target[i, 0], self.target[i, 1], float(self.arena.height_at(self.target[i]))])
