"""Env modes: each bundles a reward, a termination and an observation for the env core
(the `Mode` interface, `actors/envs/modes/base.py`). `EnvConfig.mode` names one of `MODES`;
a new mode is a class registered here with `register_mode`."""
from __future__ import annotations

from actors.envs.modes.movingcam.mode import MovingcamMode
from actors.envs.modes.sfv.mode import SfvMode

MODES: dict[str, type] = {}


def register_mode(mode: type) -> None:
    if mode.name in MODES:
        raise ValueError(f"env mode {mode.name!r} is already registered")
    MODES[mode.name] = mode


def mode_class(name: str) -> type:
    try:
        return MODES[name]
    except KeyError:
        raise ValueError(f"env mode must be one of {tuple(MODES)}, got {name!r}") from None


register_mode(SfvMode)
register_mode(MovingcamMode)
MODE_NAMES = tuple(MODES)
