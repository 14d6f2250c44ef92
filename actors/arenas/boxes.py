"""The flat floor with the scene's boxes: an `Arena` (`actors/arenas/base.py`), registered as "boxes".

Each box is a static world geom with one explicit contact pair per walker geom (the arena's
rule: no broad phase, so every collision is listed). The compiled model serves every scene
vector e: `set_scene(model, e)` moves and resizes the box geoms in place (position, half
sizes, bounding radius and box), so scene fitting (002 section 5.3, SLSQP) and per-episode
scene randomisation never recompile. Fall links touching a box count as a fall as on the
floor (`actors/envs/falls.py`: every contact of such a link is a fall), which is 002 section 5.2's
"collision with obstacles" termination for the torso and head.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from actors.arenas.flat import FlatFloor
from actors.arenas.scene import Scene, SceneFrame

BOX_RGBA = "0.42 0.58 0.42 1"  # green: apart from the tan character, the blue ghost and the grey floor
MIN_HALF_HEIGHT = 5e-4  # m: a box of height 0 (in its domain) stays a valid 1 mm slab, flush with the floor


@dataclass(frozen=True)
class BoxArena:
    scene: Scene
    frame: SceneFrame = SceneFrame()
    floor: FlatFloor = FlatFloor()
    terrain = None  # level ground under the boxes

    @property
    def geom_name(self) -> str:  # the floor's (Humanoid reads it)
        return self.floor.geom_name

    @property
    def box_names(self) -> tuple[str, ...]:
        return tuple(f"box_{i}" for i in range(self.scene.num_boxes))

    def assets_xml(self) -> str:
        return self.floor.assets_xml()

    def worldbody_xml(self) -> str:
        quat = f"{np.cos(self.frame.yaw / 2):.8g} 0 0 {np.sin(self.frame.yaw / 2):.8g}"
        geoms = []
        for name, box in zip(self.box_names, self.scene.boxes):
            pos, half = self._placement(box)
            geoms.append(f'<geom name="{name}" type="box" size="{_fmt(half)}" pos="{_fmt(pos)}" quat="{quat}" rgba="{BOX_RGBA}"/>')
        return "\n    ".join([self.floor.worldbody_xml(), *geoms])

    def contact_pairs_xml(self, walker_geoms: Sequence[tuple[str, str]], friction: float) -> str:
        spec = f"{friction} {friction} 0.005 0.0001 0.0001"
        pairs = [self.floor.contact_pairs_xml(walker_geoms, friction)]
        pairs += [f'<pair name="{box}_{name}" geom1="{box}" geom2="{geom}" condim="3" friction="{spec}"/>'
                  for box in self.box_names for name, geom in walker_geoms]
        return "\n    ".join(pairs)

    # ------------------------------------------------------------------ runtime
    def obstacle_geom_ids(self, model: mujoco.MjModel) -> tuple[int, ...]:
        """The Arena interface's obstacles: the boxes."""
        return self.box_geom_ids(model)

    def box_geom_ids(self, model: mujoco.MjModel) -> tuple[int, ...]:
        """Geom ids of the boxes, in scene order (for obstacle-collision checks)."""
        return tuple(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name) for name in self.box_names)

    def set_scene(self, model: mujoco.MjModel, e) -> None:
        """Put the boxes at scene vector e ([along, height] per box) in this compiled model."""
        placed = self.scene.with_vector(e)
        ids = list(self.box_geom_ids(model))
        for geom, box in zip(ids, placed.boxes):
            model.geom_pos[geom], half = self._placement(box)
            model.geom_size[geom] = half
            model.geom_rbound[geom] = float(np.linalg.norm(half))  # the pair mid-phase's sphere test reads it
            model.geom_aabb[geom] = np.concatenate((np.zeros(3), half))

    def _placement(self, box) -> tuple[np.ndarray, np.ndarray]:
        """World centre and half sizes of a box: top face at its height, bottom on the floor."""
        half = np.array([box.size[0] / 2, box.size[1] / 2, max(box.height / 2, MIN_HALF_HEIGHT)])
        xy = self.frame.to_world(box.along, box.lateral)
        return np.array([xy[0], xy[1], box.height - half[2]]), half


def _fmt(v) -> str:
    return " ".join(f"{x:.8g}" for x in np.ravel(v))


def scene_arena(scene: Scene, motion) -> BoxArena:
    """The arena of `scene` in the frame of `motion`'s first frame, boxes at the scene's e."""
    return BoxArena(scene, SceneFrame.of_motion(motion))
