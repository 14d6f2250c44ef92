"""What counts as a fall: which links may touch the ground, per clip, and the detector.

DeepMimic ends an episode when any body but the feet touches the ground
(`--fall_contact_bodies 0 1 2 3 4 6 7 8 9 10 12 13 14` in `args/train_humanoid3d_*_args.txt`:
every link but the two ankles). Clips whose skill puts other links on the ground list them:
the cartwheel also allows the hands (wrists), the crawl lets everything but the root, chest
and neck touch, and the rolls and getups have no fall rule at all. Our earlier rule (root,
chest and neck only) let a policy drop onto its knees and shoulders and "survive" 18 s lying
there; this module is the one definition training and evaluation share.

`StrictFall` adds a root-height floor on top of the contacts (`MIN_ROOT_HEIGHT`): a
character whose pelvis is below it is down whatever touches the floor. Evaluation always
uses the strict rule of the clip, whatever the training's termination was.
"""
from __future__ import annotations

import mujoco
import numpy as np

from actors.character.characters import CHARACTER_NAMES
from actors.character.humanoid3d import HUMANOID3D

# Links that may touch the ground beyond the character's feet (every clip allows those), per
# DeepMimic clip (from its train args), by role so that every body reads them: "hands" are the
# end effectors that are not feet (humanoid3d's wrists, the G1's wrist-yaw links); the crawl's
# are every link but the torso and head.
_EXTRA_ALLOWED: dict[str, str] = {"cartwheel": "hands"}
_ALL_BUT_TORSO_CLIPS = ("crawl",)
# Clips DeepMimic trains with no fall rule (the skill is on the ground).
NO_FALL_CLIPS = ("roll", "getup_facedown", "getup_faceup")
# Pelvis height (m) below which the character counts as down in evaluation. Standing, the
# root is at 0.89 m, at the bottom of a walk or run step ~0.8 m, at the lowest point of the
# backflip's crouch and the cartwheel ~0.45 m; kneeling puts it at ~0.5 m, but knees on the
# floor are already a contact fall. 0.3 m is a character sitting or lying.
MIN_ROOT_HEIGHT = 0.3
# Clips whose pelvis belongs below that floor: the crawl's reference pelvis is 0.17-0.40 m
# high (on hands and knees), so the floor would call every crawl a fall in its first steps
# (measured: strict evaluation NR .01, episodes of 0.25 s, for a policy whose training
# episodes of the same states ran 20 s without a contact fall). Their contact rule stays.
LOW_CLIPS = ("crawl",)


def clip_key(motion_name: str) -> str:
    """'deepmimic:cartwheel', 'humanoid3d_cartwheel' or a path's stem -> 'cartwheel'; a
    mirrored clip ('cartwheel_mirror') has its original's rule (the allowed links come in
    left/right pairs, so the rule is its own mirror image), and so has a clip retargeted onto
    a robot ('deepmimic:cartwheel_g1', `actors/motion/robot_retarget.py` names it so)."""
    name = motion_name.rsplit("/", 1)[-1].split(":", 1)[-1]
    name = name.rsplit(".", 1)[0] if name.endswith((".txt", ".json", ".npz")) else name
    for character in CHARACTER_NAMES:
        name = name.removesuffix("_" + character)
    return name.removeprefix("humanoid3d_").removesuffix("_mirror")


def _role_links(role: str, character) -> tuple[str, ...]:
    """The character's links of a role of `_EXTRA_ALLOWED`."""
    if role == "hands":
        return tuple(character.link_names[i] for i in character.end_effector_links if character.link_names[i] not in character.feet)
    raise ValueError(f"internal: no link role {role!r}")


def allowed_contact_links(motion_name: str, override: tuple[str, ...] | None = None, character=HUMANOID3D) -> tuple[str, ...]:
    """Names of the character's links that may touch the ground without a fall, for this clip.

    `override` (EnvConfig.ground_contact_links) replaces the clip's table entry; the feet
    are always allowed. A clip with no fall rule allows every link."""
    key, names = clip_key(motion_name), character.link_names
    if override is not None:
        unknown = [n for n in override if n not in names]
        if unknown:
            raise ValueError(f"ground contact links {unknown} are not links of the {character.name} ({', '.join(names)})")
        extra = tuple(override)
    elif key in NO_FALL_CLIPS:
        extra = names
    elif key in _ALL_BUT_TORSO_CLIPS:
        extra = tuple(n for i, n in enumerate(names) if i not in character.torso_links)
    else:
        extra = _role_links(_EXTRA_ALLOWED[key], character) if key in _EXTRA_ALLOWED else ()
    return tuple(n for n in names if n in character.feet or n in extra)


def fall_contact_links(motion_name: str, override: tuple[str, ...] | None = None, character=HUMANOID3D) -> np.ndarray:
    """Link indices of the character's links whose ground contact is a fall."""
    allowed = set(allowed_contact_links(motion_name, override, character))
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
    def for_clip(cls, humanoid, motion_name: str, override: tuple[str, ...] | None = None, strict: bool = False) -> "FallDetector":
        """The clip's contact rule; `strict` adds the root-height floor (evaluation), except
        for clips that are meant to be on the ground or low (`LOW_CLIPS`)."""
        key = clip_key(motion_name)
        no_floor = key in LOW_CLIPS or (override is None and key in NO_FALL_CLIPS)
        height = MIN_ROOT_HEIGHT if strict and not no_floor else None
        return cls(humanoid, fall_contact_links(motion_name, override, humanoid.character), height)
