"""What counts as a fall: which links may touch the ground, per clip, and the detector.

DeepMimic ends an episode when any body but the feet touches the ground
(`--fall_contact_bodies 0 1 2 3 4 6 7 8 9 10 12 13 14` in `args/train_humanoid3d_*_args.txt`:
every link but the two ankles), and lists for some clips the other links their skill puts on the
ground. Here a clip's rule comes from its own reference (`ground_facts.py`: measured on the
character's body over one pass of the clip), never from its name:
- a torso that comes within `LYING_M` of the ground: the skill lies on the ground (rolls,
  get-ups), so there is no fall rule;
- else a pelvis that goes below `MIN_ROOT_HEIGHT`: the skill is low (the crawl, on hands and
  knees), so every link but the torso may touch;
- else the links that touch the ground (within `CONTACT_M`) in the reference may touch it (the
  cartwheel's hands), with their left/right partners (so a clip and its mirror image share the
  rule, and the G1's cartwheel, whose retargeted right hand stays 4 cm clear, keeps both hands),
  besides the feet.
On DeepMimic's 15 clips this gives DeepMimic's own lists (tests/actors/envs/test_ground_facts.py);
a user's cartwheel BVH gets its hands allowed the same way. Measured margins: torsos of the
lying clips come within 0.03 m (get-up face down) or touch; the crawl's stays 0.09 m clear, the
others' >= 0.3 m. Hands touch in the cartwheel (0.00 m); the closest other non-foot link of an
upright clip is the run's shin at 0.02 m.

`StrictFall` adds a root-height floor on top of the contacts (`MIN_ROOT_HEIGHT`): a
character whose pelvis is below it is down whatever touches the floor. Evaluation always
uses the strict rule of the clip, whatever the training's termination was.
"""
from __future__ import annotations

import mujoco
import numpy as np

from actors.character.humanoid3d import HUMANOID3D
from actors.envs.ground_facts import GroundFacts, track_ground_facts

# Pelvis height (m) below which the character counts as down in evaluation. Standing, the
# root is at 0.89 m, at the bottom of a walk or run step ~0.8 m, at the lowest point of the
# backflip's crouch and the cartwheel ~0.45 m; kneeling puts it at ~0.5 m, but knees on the
# floor are already a contact fall. 0.3 m is a character sitting or lying. A clip whose own
# pelvis goes lower (the crawl's: 0.17-0.40 m) has no floor: it would call every crawl a fall.
MIN_ROOT_HEIGHT = 0.3
CONTACT_M = 0.01  # a link whose lowest point comes this close to the ground in the reference touches it
LYING_M = 0.05  # a torso this close to the ground in the reference: the skill lies on the ground


def lies_on_the_ground(facts: GroundFacts) -> bool:
    return facts.torso_clearance_m <= LYING_M


def goes_low(facts: GroundFacts) -> bool:
    return facts.lowest_root_m < MIN_ROOT_HEIGHT


def allowed_contact_links(facts: GroundFacts, override: tuple[str, ...] | None = None, character=HUMANOID3D) -> tuple[str, ...]:
    """Names of the character's links that may touch the ground without a fall, for a clip with these facts.

    `override` (EnvConfig.ground_contact_links) replaces the clip's own allowance; the feet
    are always allowed. A clip that lies on the ground allows every link."""
    names = character.link_names
    if override is not None:
        unknown = [n for n in override if n not in names]
        if unknown:
            raise ValueError(f"ground contact links {unknown} are not links of the {character.name} ({', '.join(names)})")
        extra = tuple(override)
    elif lies_on_the_ground(facts):
        extra = names
    elif goes_low(facts):
        extra = tuple(n for i, n in enumerate(names) if i not in character.torso_links)
    else:
        touching = set(facts.links_within(CONTACT_M))
        extra = tuple(names[i] for i in sorted(touching | {int(character.link_mirror[i]) for i in touching}))
    return tuple(n for n in names if n in character.feet or n in extra)


def fall_contact_links(facts: GroundFacts, override: tuple[str, ...] | None = None, character=HUMANOID3D) -> np.ndarray:
    """Link indices of the character's links whose ground contact is a fall."""
    allowed = set(allowed_contact_links(facts, override, character))
    return np.array([i for i, name in enumerate(character.link_names) if name not in allowed], dtype=np.int64)


def body_geom_mask(model: mujoco.MjModel, bodies) -> np.ndarray:
    """(ngeom,) bool: the geoms of the bodies `bodies` (MuJoCo body ids)."""
    mask = np.zeros(model.ngeom, dtype=bool)
    for body in bodies:
        start, count = model.body_geomadr[body], model.body_geomnum[body]
        mask[start:start + count] = True
    return mask


class FallDetector:
    """Ground contact of a fall link (and, with `min_root_height`, a pelvis too low).

    Contacts are the humanoid's explicit floor pairs, so any contact of a fall link's geom
    is with the ground (or a scene object: those count too, as in DeepMimic)."""

    def __init__(self, humanoid, links: np.ndarray, min_root_height: float | None = None):
        self.links = np.asarray(links, dtype=np.int64)
        self.min_root_height = min_root_height
        self.mask = body_geom_mask(humanoid.model, humanoid.body_ids[self.links])
        self.mask[humanoid.floor_geom_id] = False
        link_of_body = np.full(humanoid.model.nbody, -1, dtype=np.int64)
        link_of_body[humanoid.body_ids] = np.arange(len(humanoid.body_ids))
        self._geom_link = link_of_body[humanoid.model.geom_bodyid]  # -1 for the arena's geoms
        self._root_z_index = 2  # qpos[2]: the free root's height

    def touching(self, data: mujoco.MjData) -> int:
        """Bitmask over the character's links (bit i: link i) of the fall links touching the ground
        now; 0 when none does (what ended an episode, for the training metrics)."""
        if data.ncon == 0 or not self.links.size:
            return 0
        geoms = data.contact.geom[:data.ncon]
        hits = self._geom_link[geoms[self.mask[geoms]]]
        return int(np.bitwise_or.reduce(np.left_shift(1, hits))) if hits.size else 0

    def __call__(self, data: mujoco.MjData) -> bool:
        if self.min_root_height is not None and data.qpos[self._root_z_index] < self.min_root_height:
            return True
        if data.ncon == 0 or not self.links.size:
            return False
        return bool(self.mask[data.contact.geom].any())

    @classmethod
    def for_facts(cls, humanoid, facts: GroundFacts, override: tuple[str, ...] | None = None,
                  strict: bool = False) -> "FallDetector":
        """The contact rule of a clip with these facts; `strict` adds the root-height floor
        (evaluation), except for clips that go low (without an override, lying ones too)."""
        lying = lies_on_the_ground(facts)
        no_floor = (goes_low(facts) and not lying) or (override is None and lying)
        height = MIN_ROOT_HEIGHT if strict and not no_floor else None
        return cls(humanoid, fall_contact_links(facts, override, humanoid.character), height)

    @classmethod
    def for_track(cls, humanoid, track, override: tuple[str, ...] | None = None, strict: bool = False) -> "FallDetector":
        """The rule of the clip a reference track plays (its facts measured on `humanoid`)."""
        return cls.for_facts(humanoid, track_ground_facts(humanoid, track), override, strict)
