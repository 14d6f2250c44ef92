"""Flags shared by the commands that put a trained policy on terrain (eval, render).

`--terrain KIND --terrain-difficulty D --terrain-seed K`: every episode on a fresh terrain of
KIND at difficulty D (no curriculum), episode k's drawn from [K, seed + k], so seeds training
never used give ground it never saw (`docs/terrain.md`). A run trained on terrain keeps its kind
unless told; one trained on the flat has no heightmap in its observation and walks blind.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable


def add_terrain_args(p) -> None:
    p.add_argument("--terrain", default=None, metavar="KIND",
                   help="slopes, gaps, steps, rough or mixed: every episode on a fresh terrain of this kind (default: the run's ground)")
    p.add_argument("--terrain-difficulty", default=None, metavar="D",
                   help="difficulty in [0, 1] (1: grades to 15 %%, gaps to 40 cm, steps to 15 cm; default 1 or the run's top)")
    p.add_argument("--terrain-seed", default=None, metavar="K",
                   help="seed of the terrains (episode k's from [K, seed + k]); give seeds training did not use (it used 0)")


def terrain_change(args, command: str) -> Callable | None:
    """A function of the run's `EnvConfig` that puts it on the flags' terrain; None without terrain flags."""
    from actors.arenas.terrain_generators import check_terrain
    from learner.errors import SfvError

    if args.terrain is None and args.terrain_difficulty is None and args.terrain_seed is None:
        return None
    difficulty = _parse(args.terrain_difficulty, float, "--terrain-difficulty", command)
    seed = _parse(args.terrain_seed, int, "--terrain-seed", command)
    try:
        check_terrain(args.terrain, 0.0 if difficulty is None else difficulty)
    except ValueError as exc:
        raise SfvError(f"{command}: {exc}") from None

    def change(config):
        kind = args.terrain or config.terrain
        if kind is None:
            raise SfvError(f"{command}: --terrain-difficulty and --terrain-seed need --terrain KIND (the run trained on the flat floor)")
        top = config.terrain_difficulty if config.terrain is not None else 1.0
        return dataclasses.replace(config, terrain=kind, terrain_difficulty=top if difficulty is None else difficulty,
                                   terrain_seed=config.terrain_seed if seed is None else seed, terrain_curriculum=False,
                                   heightmap=config.terrain is not None and config.heightmap)
    return change


def _parse(text, kind, flag: str, command: str):
    from learner.errors import SfvError

    if text is None:
        return None
    try:
        value = kind(text)
    except ValueError:
        raise SfvError(f"{command}: {flag} must be {'an integer' if kind is int else 'a number'}, got {text!r}") from None
    if kind is float and not math.isfinite(value):
        raise SfvError(f"{command}: {flag} must lie in [0, 1], got {text}")
    return value
