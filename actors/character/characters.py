"""The registry of characters: the bodies an env can build, by name (`EnvConfig.character`).

A new body is a `Character` (`actors/character/base.py`) registered here with
`register_character`; the env core, the reward, the fall rule, the observation and the
evaluation read everything else from the description itself. How a reference motion reaches a
body's pose space (its own files, a humanoid clip retargeted) is `actors/motion/character_reference.py`.
"""
from __future__ import annotations

from actors.character.g1 import G1_ROBOT
from actors.character.humanoid3d import HUMANOID3D

CHARACTERS: dict[str, object] = {}


def register_character(character) -> None:
    if character.name in CHARACTERS:
        raise ValueError(f"character {character.name!r} is already registered")
    CHARACTERS[character.name] = character


def character_named(name: str):
    """The registered character called `name` (ValueError naming the registered ones)."""
    try:
        return CHARACTERS[name]
    except KeyError:
        raise ValueError(f"character must be one of {', '.join(CHARACTERS)}, got {name!r}") from None


register_character(HUMANOID3D)
register_character(G1_ROBOT)
CHARACTER_NAMES = tuple(CHARACTERS)
