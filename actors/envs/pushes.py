"""Random horizontal pushes on the character's root, to show how a policy recovers.

A push is an impulse J (N s) in a random horizontal direction, delivered as a constant force
J / T on the root body (`MjData.xfrc_applied`) for T seconds. The env advances physics in
blocks of one control step, so T is rounded to whole control steps (0.1 s = 3 steps at
30 Hz). An episode's pushes land at random, non-overlapping times after a settling delay:
the window is cut into one slot per push and each push starts at a random step of its slot.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class PushConfig:
    count: int = field(default=0, metadata={"help": "pushes per episode"})
    impulse: float = field(default=40.0, metadata={"help": "impulse of one push in N s (40 N s changes a 45 kg character's speed by ~0.9 m/s)"})
    duration_s: float = field(default=0.1, metadata={"help": "how long the push force acts, rounded to whole control steps"})
    settle_s: float = field(default=0.5, metadata={"help": "no push during the first seconds of an episode"})


class PushSchedule:
    """Which control steps of one episode carry which root force."""

    def __init__(self, config: PushConfig, control_hz: float, episode_steps: int, rng: np.random.Generator):
        self.steps_per_push = max(1, int(round(config.duration_s * control_hz)))
        magnitude = config.impulse / (self.steps_per_push / control_hz)
        first = min(int(round(config.settle_s * control_hz)), episode_steps)
        window = max(0, episode_steps - first - self.steps_per_push)
        count = min(config.count, window // self.steps_per_push) if config.count > 0 else 0
        slot = window // count if count else 0
        self.starts = np.array([first + k * slot + int(rng.integers(max(1, slot - self.steps_per_push + 1))) for k in range(count)], dtype=np.int64)
        angles = rng.uniform(0.0, 2.0 * np.pi, count)
        self.forces = np.zeros((count, 3))
        self.forces[:, 0] = magnitude * np.cos(angles)
        self.forces[:, 1] = magnitude * np.sin(angles)

    def active(self, step: int) -> int:
        """Index of the push acting during control step `step` (the step from `step` to `step + 1`), or -1."""
        k = int(np.searchsorted(self.starts, step, side="right")) - 1
        return k if k >= 0 and step < self.starts[k] + self.steps_per_push else -1


def apply_push(data, root_body: int, schedule: PushSchedule | None, step: int) -> np.ndarray | None:
    """Set (or clear) the root force for control step `step`; returns the force when a push acts."""
    data.xfrc_applied[root_body, :3] = 0.0
    k = schedule.active(step) if schedule is not None else -1
    if k < 0:
        return None
    data.xfrc_applied[root_body, :3] = schedule.forces[k]
    return schedule.forces[k]
