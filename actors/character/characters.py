"""The registry of characters: the bodies an env can build, by name (`EnvConfig.character`).

A new body is a `Character` (`actors/character/base.py`) registered here with
`register_character`; the env core, the reward, the fall rule, the observation and the
evaluation read everything else from the description itself. How a reference motion reaches a
body's pose space (its own files, a humanoid clip retargeted) is `actors/motion/character_reference.py`.
"""
from __future__ import annotations

from actors.character.g1 import G1_ROBOT
from actors.character.humanoid3d import HUMANOID3D
from learner.registry import Registry

CHARACTERS = Registry("character")


def register_character(character) -> None:
    CHARACTERS.register(character.name, character)


def character_named(name: str):
    """The registered character called `name` (ValueError naming the registered ones)."""
    return CHARACTERS.named(name)


register_character(HUMANOID3D)
register_character(G1_ROBOT)
CHARACTER_NAMES = tuple(CHARACTERS)
