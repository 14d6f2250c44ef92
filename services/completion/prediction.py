"""Simulating the chosen skill's policy (deterministic) from q_bar."""
from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from services.completion.library import Skill


@dataclass
class PredictionStep:
    step: int  # control steps simulated so far (0 right after the reset)
    fell: bool  # the torso or head touched the ground (or the simulation diverged)
    done: bool  # fell, reached the requested length, or the env's horizon / the clip's end


def predict(skill: Skill, row: int, state: np.ndarray, steps: int) -> Iterator[PredictionStep]:
    """Reset `skill.env` to `state` at reference row `row`, then step the policy up to `steps`
    times; yields after the reset and after every step, so the caller can film `env.data`."""
    env = skill.env
    # row / start_steps is the phase that `ReferenceTrack.start_index` maps back to exactly `row`.
    phase = row / env.track.start_steps
    obs, info = env.reset(options={"init": "state", "phase": phase, "state": state})
    assert info["start_step"] == row, (info, row)
    obs_row = np.empty((1, env.observation_space.shape[0]), np.float32)
    obs_row[0] = obs
    progress = PredictionStep(0, False, steps == 0)
    yield progress
    for step in range(1, steps + 1):
        action, _ = skill.policy.act(obs_row, deterministic=True)
        obs, _, terminated, truncated, _ = env.step(action[0])
        obs_row[0] = obs
        progress.step, progress.fell = step, bool(terminated)
        progress.done = bool(terminated or truncated or step == steps)
        yield progress
        if progress.done:
            return
