"""The task envs' fall: a link other than the feet on the floor, the torso or head on a prop,
or the pelvis below 0.3 m.

`actors/envs/falls.py`'s detector counts any contact of a fall link, which in an arena with a box
would end an episode whenever a hand touched the box: the one thing push-box asks for. 004
Supp. D's rule is the same as this one: contact between a non-foot geom of the walker and the
ground plane. The pelvis-height floor is the strict evaluation rule of `actors/envs/falls.py`, used
in training too so that training and `sfv task eval` count the same falls.

Deviation from 004: the torso or head (pelvis, chest, neck: `FALL_CONTACT_LINKS`) resting on a
prop (any geom that is neither the floor nor the walker's, the push box) is a fall too. A
joint-space policy trained without it learnt to prop its torso on the box and shove it while
its pelvis stayed above 0.3 m and its feet alone touched the floor: a collapse the floor rule
cannot see. Hands and arms may touch the box; pushing is what the task asks.

On a slope (`actors/arenas/slope.py`) the pelvis's height is measured from the ground under it:
0.3 m above z = 0 is 0.75 m under the incline 5 m downhill of the origin on a 15 % grade.
"""
from __future__ import annotations

import mujoco

from actors.envs.falls import MIN_ROOT_HEIGHT, FallDetector, body_geom_mask, fall_contact_links
from actors.envs.ground_facts import GroundFacts


class FloorFall(FallDetector):
    def __init__(self, humanoid, ground=None):
        """`ground`: anything with `height_at(xy)` (a slope) to measure the pelvis from; None: z = 0."""
        upright = GroundFacts.upright(humanoid.character)  # the feet may touch, nothing else
        super().__init__(humanoid, fall_contact_links(upright, character=humanoid.character), MIN_ROOT_HEIGHT)
        model = humanoid.model
        self.floor = humanoid.floor_geom_id
        self.trunk = body_geom_mask(model, humanoid.body_ids[humanoid.character.torso_links])
        self.prop = ~body_geom_mask(model, humanoid.body_ids)
        self.prop[self.floor] = False
        self.has_props = bool(self.prop.any())
        self.ground = ground

    def __call__(self, data: mujoco.MjData) -> bool:
        height = data.qpos[self._root_z_index]
        if self.ground is not None:
            height -= float(self.ground.height_at(data.qpos[:2]))
        if height < self.min_root_height:
            return True
        if data.ncon == 0:
            return False
        geoms = data.contact.geom
        on_floor = (geoms == self.floor).any(axis=1)
        if self.mask[geoms[on_floor]].any():
            return True
        if not self.has_props:
            return False
        return bool((self.trunk[geoms] & self.prop[geoms[:, ::-1]]).any())
