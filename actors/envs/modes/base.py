"""The mode interface: what an env mode plugs into the env core (`actors/envs/core.py`).

A mode bundles the reward, the termination and the observation of one way of following a
reference. The core builds one per batch, `Mode(config, track, humanoid, batch)`, and each
control step, after the physics and the feature capture, asks it for the rewards of the
batch (setting `terminated`, its own early termination) and to write its slots of the
observations. What the mode says about the reference root (`tracks_root`) picks the root
sync and the reference-root observation the core builds. A new mode is a class with these
members registered in `actors/envs/modes/__init__.py`.
"""
from __future__ import annotations

from typing import Protocol

import numpy as np


class Mode(Protocol):
    name: str
    term_names: tuple[str, ...]  # the reward terms' names, as many as the core's term columns
    tracks_root: bool  # the reference's root path is followed: root sync and reference-root observations
    characters: tuple[str, ...] | None  # the bodies the mode can follow (None: any `Character`)
    max_reward: float  # the most one control step earns from the mode's reward
    terminated: np.ndarray  # (B,) bool: the mode's own termination of the last `rewards`
    captures: tuple  # per-env callables (i, data) run right after each env's physics step

    def rewards(self, rows: np.ndarray, features, sim, ref, terms: np.ndarray, check_termination: bool) -> np.ndarray:
        """(B,) rewards of the captured envs at reference `rows`; `terms` (B, T) gets the terms."""
        ...

    def reward_one(self, data, row_buf: np.ndarray, features, sim, ref, terms: np.ndarray) -> float:
        """The reward of one env's current state (`data`) against the reference at `row_buf[0]`."""
        ...

    def observe(self, rows: np.ndarray, out: np.ndarray) -> None:
        """Write the mode's slots of the observations `out` (B, features)."""
        ...

    def set_obstacles(self, geom_ids: tuple[int, ...]) -> None: ...
