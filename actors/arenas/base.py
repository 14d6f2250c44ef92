"""The Arena interface: what the character stands in.

An arena is composed with the character into one MuJoCo model (`build_mjcf(config, arena)`,
dm_control's walker-in-an-arena split): it brings its assets, its world geoms and the explicit
contact pairs between them and the character's geoms (every geom's contype/conaffinity is 0,
so anything that should collide lists its pairs). An arena may add free bodies after the
character (`props_xml`), so the character keeps the first coordinates of qpos / qvel.

At run time the env core asks it for its obstacles (geoms whose contact ends a movingcam
episode) and, when it has a `scene` (boxes that move per episode), to `set_scene(model, e)`.
A new terrain is a class with these members, registered in `actors/arenas/__init__.py`;
ground that is not level is a height field (`terrain.py`: slopes, gaps, steps, rough, mixed).
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol, runtime_checkable


@runtime_checkable
class Arena(Protocol):
    geom_name: str  # the ground geom (the fall rule and the feet's contacts look it up)
    scene: Any  # a `Scene` whose vector e moves props per episode (`set_scene`), or None
    terrain: Any  # a `TerrainArena` whose height field is drawn per episode (`actors/arenas/terrain.py`), or None

    def assets_xml(self) -> str: ...

    def worldbody_xml(self) -> str: ...

    def contact_pairs_xml(self, walker_geoms: Sequence[tuple[str, str]], friction: float) -> str:
        """Contact pairs of the arena's geoms with the walker's (pair name suffix, geom name)."""
        ...

    def obstacle_geom_ids(self, model) -> tuple[int, ...]:
        """Geom ids, in the compiled model, of what the character must not run into."""
        ...
