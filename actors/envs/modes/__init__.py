"""Env modes: each bundles a reward, a termination and an observation for the env core
(the `Mode` interface, `actors/envs/modes/base.py`). `EnvConfig.mode` names one of `MODES`;
a new mode is a class registered here with `register_mode`."""
from __future__ import annotations

from actors.envs.modes.movingcam.mode import MovingcamMode
from actors.envs.modes.sfv.mode import SfvMode
from learner.registry import Registry

MODES = Registry("env mode")


def register_mode(mode: type) -> None:
    MODES.register(mode.name, mode)


def mode_class(name: str) -> type:
    return MODES.named(name)


register_mode(SfvMode)
register_mode(MovingcamMode)
MODE_NAMES = tuple(MODES)
