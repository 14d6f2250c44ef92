"""The task envs' fall: a link other than the feet on the floor, or the pelvis below 0.3 m.

`actors/falls.py`'s detector counts any contact of a fall link, which in an arena with a box
would end an episode whenever a hand touched the box: the one thing push-box asks for. 004
Supp. D's rule is the same as this one: contact between a non-foot geom of the walker and the
ground plane. The pelvis-height floor is the strict evaluation rule of `actors/falls.py`, used
in training too so that training and `sfv task eval` count the same falls.
"""
from __future__ import annotations

import mujoco

from actors.falls import MIN_ROOT_HEIGHT, FallDetector, fall_contact_links


class FloorFall(FallDetector):
    def __init__(self, humanoid):
        super().__init__(humanoid, fall_contact_links("walk"), MIN_ROOT_HEIGHT)  # the feet may touch, nothing else
        self.floor = humanoid.floor_geom_id

    def __call__(self, data: mujoco.MjData) -> bool:
        if data.qpos[self._root_z_index] < self.min_root_height:
            return True
        if data.ncon == 0:
            return False
        geoms = data.contact.geom
        on_floor = (geoms == self.floor).any(axis=1)
        return bool(self.mask[geoms[on_floor]].any())
