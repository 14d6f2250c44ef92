"""Arenas: what the character stands in (the `Arena` interface, `actors/arenas/base.py`).

The registry names each arena; the env core asks it for the arena of its config
(`arena_for`) and the task envs for theirs by name (`make_arena`). A new arena is an `Arena`
registered here with `register_arena("name", Factory)`; slopes, gaps, steps and rough ground are
the "terrain" arena's kinds (`actors/arenas/terrain.py`).
"""
from __future__ import annotations

from collections.abc import Callable

from actors.arenas.base import Arena
from actors.arenas.boxes import BoxArena, scene_arena
from actors.arenas.flat import FlatFloor
from actors.arenas.push_box import PushBoxArena
from actors.arenas.scene import load_scene
from actors.arenas.terrain import TerrainArena, terrain_arena

ARENAS: dict[str, Callable[..., Arena]] = {}


def register_arena(name: str, factory: Callable[..., Arena]) -> None:
    """Make `factory(**kwargs)` the arena called `name` (a name is registered once)."""
    if name in ARENAS:
        raise ValueError(f"arena {name!r} is already registered")
    ARENAS[name] = factory


def make_arena(name: str, **kwargs) -> Arena:
    try:
        factory = ARENAS[name]
    except KeyError:
        raise ValueError(f"unknown arena {name!r}; registered: {sorted(ARENAS)}") from None
    return factory(**kwargs)


def _boxes(scene_path: str, motion, check_start_pose: bool = True) -> BoxArena:
    """The boxes of a scene file, in `motion`'s first-frame frame, checked against its start pose."""
    return scene_arena(load_scene(scene_path, motion if check_start_pose else None), motion)


register_arena("flat", FlatFloor)
register_arena("boxes", _boxes)
register_arena("push_box", PushBoxArena)
register_arena("terrain", terrain_arena)


def arena_for(scene_path: str | None, motion, check_start_pose: bool = True, terrain: str | None = None,
              horizon_s: float = 20.0) -> Arena:
    """The imitation env's arena: the flat floor, a scene file's boxes, or a `terrain` kind's
    height field under the clip's path over `horizon_s`."""
    if terrain is not None:
        if scene_path is not None:
            raise ValueError("--terrain and --scene do not go together (boxes stand on the flat floor)")
        return make_arena("terrain", kind=terrain, motion=motion, horizon_s=horizon_s)
    if scene_path is None:
        return make_arena("flat")
    return make_arena("boxes", scene_path=scene_path, motion=motion, check_start_pose=check_start_pose)


__all__ = ["ARENAS", "Arena", "BoxArena", "FlatFloor", "PushBoxArena", "TerrainArena", "arena_for", "make_arena", "register_arena"]
