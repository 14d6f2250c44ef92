"""What a clip's reference does near the ground, measured on the character's own body: how low
its pelvis goes, how close its torso comes, and how close each link comes (one pass of the clip,
the reference's kinematic poses on flat ground at z = 0, whatever arena the env builds).

`falls.py` turns these facts into the clip's fall rule, so a user's cartwheel BVH gets its hands
allowed because its hands touch the ground, not because of its name. The links measured are
those with ground contact pairs (the ones a fall detector can see); a link with none is never
near the ground (its clearance is infinite).
"""
from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

_SPHERE, _CAPSULE, _ELLIPSOID, _CYLINDER = (int(mujoco.mjtGeom.mjGEOM_SPHERE), int(mujoco.mjtGeom.mjGEOM_CAPSULE),
                                            int(mujoco.mjtGeom.mjGEOM_ELLIPSOID), int(mujoco.mjtGeom.mjGEOM_CYLINDER))


@dataclass(frozen=True)
class GroundFacts:
    lowest_root_m: float  # the pelvis's (free root's) lowest height over the clip
    link_clearance_m: tuple[float, ...]  # per link: its lowest point's lowest height (negative: in the ground)
    torso_links: tuple[int, ...]

    @property
    def torso_clearance_m(self) -> float:
        """How close the torso (the character's torso links) comes to the ground."""
        return min((self.link_clearance_m[i] for i in self.torso_links), default=float("inf"))

    def links_within(self, distance_m: float) -> tuple[int, ...]:
        """Indices of the links that come within `distance_m` of the ground."""
        return tuple(i for i, clearance in enumerate(self.link_clearance_m) if clearance <= distance_m)

    @classmethod
    def upright(cls, character) -> "GroundFacts":
        """A clip on its feet that touches nothing else (a task's default: the feet may touch)."""
        feet = {character.link_names.index(name) for name in character.feet}
        clearance = tuple(0.0 if i in feet else float("inf") for i in range(len(character.link_names)))
        return cls(float("inf"), clearance, tuple(int(i) for i in character.torso_links))


def _lowest_z(model: mujoco.MjModel, data: mujoco.MjData, geom: int) -> float:
    """The lowest world height of a geom (sphere, capsule, ellipsoid, cylinder exactly; else its box)."""
    kind, size = int(model.geom_type[geom]), model.geom_size[geom]
    z, axis_z = data.geom_xpos[geom, 2], data.geom_xmat[geom].reshape(3, 3)[2]  # row 2: the local axes' world z
    if kind == _SPHERE:
        return z - size[0]
    if kind == _CAPSULE:
        return z - abs(axis_z[2]) * size[1] - size[0]
    if kind == _ELLIPSOID:
        return z - float(np.sqrt(np.sum((axis_z * size) ** 2)))
    if kind == _CYLINDER:
        return z - abs(axis_z[2]) * size[1] - size[0] * float(np.sqrt(max(0.0, 1.0 - axis_z[2] ** 2)))
    centre, half = model.geom_aabb[geom, :3], model.geom_aabb[geom, 3:]
    return z + float(axis_z @ centre) - float(np.abs(axis_z) @ half)


def _ground_geoms_by_link(humanoid) -> dict[int, list[int]]:
    """Link index -> its geoms that have a contact pair with the ground."""
    model, floor = humanoid.model, humanoid.floor_geom_id
    paired = {int(g) for pair in zip(model.pair_geom1, model.pair_geom2) if floor in pair for g in pair if g != floor}
    link_of_body = {int(body): link for link, body in enumerate(humanoid.body_ids)}
    by_link: dict[int, list[int]] = {}
    for geom in sorted(paired):
        link = link_of_body.get(int(model.geom_bodyid[geom]))
        if link is not None:
            by_link.setdefault(link, []).append(geom)
    return by_link


def ground_facts(humanoid, qpos_rows: np.ndarray) -> GroundFacts:
    """The facts of the reference poses `qpos_rows` (T, nq) on `humanoid`'s compiled body."""
    model = humanoid.model
    data = mujoco.MjData(model)
    by_link = _ground_geoms_by_link(humanoid)
    clearance = np.full(len(humanoid.body_ids), np.inf)
    for qpos in qpos_rows:
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        for link, geoms in by_link.items():
            clearance[link] = min(clearance[link], min(_lowest_z(model, data, g) for g in geoms))
    return GroundFacts(float(np.min(qpos_rows[:, 2])), tuple(float(c) for c in clearance),
                       tuple(int(i) for i in humanoid.character.torso_links))


def track_ground_facts(humanoid, track) -> GroundFacts:
    """The facts of one pass of a reference track (its start rows: the whole clip once)."""
    return ground_facts(humanoid, track.qpos[:track.start_steps])
