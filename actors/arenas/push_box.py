"""A floor with one movable box: the arena of the push-box task (NPMP 004 §3.4, Supp. D).

004's warehouse has free boxes on pedestals that the walker carries; here one free box stands
on the floor to be pushed (no lifting: the motor modules built here come from locomotion
clips, which have no grasp). The box is a free body that `build_mjcf` places after the walker
(`props_xml`), so the walker keeps qpos[:43], qvel[:34] and bodies 1..15. Contacts stay
explicit (`actors/arenas/flat.py`): the floor's pairs with the walker, plus every walker geom
against the box and the box against the floor. The floor is flat, or SFV Fig. 8's slope
(`actors/arenas/slope.py`: the box pushed up and down a 15 % grade).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from actors.arenas.flat import FlatFloor
from actors.arenas.slope import SlopeFloor

BOX_BODY = "box"
BOX_GEOM = "box_geom"


@dataclass(frozen=True)
class PushBoxArena:
    """A floor (flat or sloped) plus a free box (half sizes in metres, mass in kg, box-floor friction)."""

    half_size: tuple[float, float, float] = (0.25, 0.25, 0.4)
    mass: float = 5.0
    floor_friction: float = 0.4
    floor: FlatFloor | SlopeFloor = FlatFloor()
    scene = None  # the box is a free body, not a scene vector
    terrain = None  # level ground

    def obstacle_geom_ids(self, model) -> tuple[int, ...]:
        return ()

    @property
    def grade(self) -> float:
        return self.floor.grade

    @property
    def gradient(self):
        return self.floor.gradient

    def height_at(self, xy):
        return self.floor.height_at(xy)

    @property
    def geom_name(self) -> str:  # the ground geom, as Humanoid and the fall rule look it up
        return self.floor.geom_name

    def assets_xml(self) -> str:
        return self.floor.assets_xml()

    def worldbody_xml(self) -> str:
        return self.floor.worldbody_xml()

    def props_xml(self) -> str:
        hx, hy, hz = self.half_size
        z = hz + self.grade * (3.0 + hx)  # clear of the ground until the first reset places it
        return (f'    <body name="{BOX_BODY}" pos="3 0 {z:.6g}"><freejoint name="box_root"/>'
                f'<geom name="{BOX_GEOM}" type="box" size="{hx} {hy} {hz}" mass="{self.mass}" rgba="0.85 0.45 0.15 1"/></body>\n')

    def contact_pairs_xml(self, walker_geoms: Sequence[tuple[str, str]], friction: float) -> str:
        box_spec = f"{friction} {friction} 0.005 0.0001 0.0001"
        floor_spec = f"{self.floor_friction} {self.floor_friction} 0.005 0.0001 0.0001"
        pairs = [self.floor.contact_pairs_xml(walker_geoms, friction),
                 f'<pair name="{self.geom_name}_box" geom1="{self.geom_name}" geom2="{BOX_GEOM}" condim="3" friction="{floor_spec}"/>']
        pairs += [f'<pair name="box_{name}" geom1="{BOX_GEOM}" geom2="{geom}" condim="3" friction="{box_spec}"/>' for name, geom in walker_geoms]
        return "\n    ".join(pairs)
