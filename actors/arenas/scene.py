"""Boxes in the scene and the scene vector e (dynamic-camera paper 002, section 5 and 5.3).

002 gives the character "a rough initial arrangement of the scene consisting of simple
geometric primitives, such as boxes", and parameterises "the location for the heading
direction and the height of each object" in a user-given domain ([-30 cm, 30 cm] in their
experiments); the policy sees e, and scene fitting (5.3) searches e. Here a box is placed in
the clip's *scene frame*: the origin is the first frame's horizontal root position, +along
the root's initial heading, +lateral to its left (`SceneFrame.of_motion`). A box stands on
the floor: its top face is at `height`, its footprint `size` = (length along the heading,
width across) is fixed, and e holds [along, height] per box, in file order.

Scene file (YAML):

    boxes:
      - name: landing        # optional (default box<i>); named in error messages
        along: 0.95          # m, centre of the box along the initial heading
        lateral: 0.0         # m, centre to the left of the heading (optional, default 0; not fitted)
        height: 0.2          # m, top face above the floor (>= 0)
        size: [0.8, 1.0]     # m, footprint: length along the heading, width across (> 0)
        domain:              # optional: [min, max] of each fitted parameter
          along: [0.65, 1.25]    # default: along +- 0.3
          height: [0.0, 0.5]     # default: height +- 0.3, floored at 0

Every fault (unknown key, wrong type, a value outside its domain, a box that could cover
the character's first-frame footprint anywhere in its along-domain) is one `SceneError`
line naming the file and the box. Examples: `bench/scenes/`.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from learner.errors import SfvError
from learner.yaml_io import read_yaml

DEFAULT_HALF_DOMAIN = 0.3  # m: 002's [-30 cm, 30 cm] per parameter
FITTED = ("along", "height")  # the scene vector's entries per box, in this order
START_MARGIN = 0.1  # m added around the first frame's link positions (the links' own thickness)
_BOX_KEYS = {"name", "along", "lateral", "height", "size", "domain"}


class SceneError(SfvError, ValueError):
    """A scene file is malformed; the message names the file and the box."""


@dataclass(frozen=True)
class SceneFrame:
    """Where the scene's axes are in the world: origin (x, y) and heading yaw (rad)."""

    origin: tuple[float, float] = (0.0, 0.0)
    yaw: float = 0.0

    @classmethod
    def of_motion(cls, motion) -> "SceneFrame":
        """The clip's first frame: root position and the yaw of the root's +x (its front)."""
        front = motion.root_front(0)
        return cls((float(motion.root_pos[0, 0]), float(motion.root_pos[0, 1])), float(np.arctan2(front[1], front[0])))

    @property
    def forward(self) -> np.ndarray:
        return np.array([np.cos(self.yaw), np.sin(self.yaw)])

    @property
    def left(self) -> np.ndarray:
        return np.array([-np.sin(self.yaw), np.cos(self.yaw)])

    def to_world(self, along, lateral) -> np.ndarray:
        """(..., 2) world xy of scene-frame coordinates."""
        along, lateral = np.asarray(along, np.float64), np.asarray(lateral, np.float64)
        return np.asarray(self.origin) + along[..., None] * self.forward + lateral[..., None] * self.left

    def to_scene(self, xy) -> np.ndarray:
        """(..., 2) (along, lateral) of world xy."""
        rel = np.asarray(xy, np.float64) - np.asarray(self.origin)
        return np.stack((rel @ self.forward, rel @ self.left), axis=-1)


@dataclass(frozen=True)
class Box:
    """A box standing on the floor, in the scene frame (metres)."""

    name: str
    along: float
    height: float
    size: tuple[float, float]  # (length along the heading, width across)
    lateral: float = 0.0
    along_domain: tuple[float, float] | None = None  # None: along +- DEFAULT_HALF_DOMAIN
    height_domain: tuple[float, float] | None = None  # None: height +- DEFAULT_HALF_DOMAIN, floored at 0

    def __post_init__(self):
        if self.along_domain is None:
            object.__setattr__(self, "along_domain", (self.along - DEFAULT_HALF_DOMAIN, self.along + DEFAULT_HALF_DOMAIN))
        if self.height_domain is None:
            object.__setattr__(self, "height_domain", (max(0.0, self.height - DEFAULT_HALF_DOMAIN), self.height + DEFAULT_HALF_DOMAIN))

    @property
    def domain(self) -> np.ndarray:
        """(2, 2): [min, max] of along, then of height."""
        return np.array([self.along_domain, self.height_domain], dtype=np.float64)


@dataclass(frozen=True)
class Scene:
    boxes: tuple[Box, ...]

    @property
    def num_boxes(self) -> int:
        return len(self.boxes)

    @property
    def vector_dim(self) -> int:
        return len(FITTED) * len(self.boxes)

    def vector(self) -> np.ndarray:
        """The scene vector e: [along, height] per box, in file order."""
        return np.array([[b.along, b.height] for b in self.boxes], dtype=np.float64).reshape(-1)

    def with_vector(self, e) -> "Scene":
        """The same boxes at the along / height of `e` (not checked against the domains)."""
        e = np.asarray(e, dtype=np.float64).reshape(self.num_boxes, len(FITTED))
        return Scene(tuple(replace(b, along=float(a), height=float(h)) for b, (a, h) in zip(self.boxes, e)))

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high), each shaped like e: the domain scene fitting and sampling stay in."""
        d = np.stack([b.domain for b in self.boxes]) if self.boxes else np.zeros((0, 2, 2))
        return d[:, :, 0].reshape(-1), d[:, :, 1].reshape(-1)

    def normalise(self, e) -> np.ndarray:
        """e mapped to [-1, 1] over the domain (0 for a parameter whose domain is one point):
        what the policy and value networks observe."""
        low, high = self.bounds()
        span = high - low
        return np.where(span > 0, 2.0 * (np.asarray(e, np.float64) - low) / np.where(span > 0, span, 1.0) - 1.0, 0.0)

    def sample(self, rng: np.random.Generator) -> np.ndarray:
        """A scene vector drawn uniformly from the domain (per-episode randomisation)."""
        low, high = self.bounds()
        return rng.uniform(low, high)

    def check_start_pose(self, source, motion) -> None:
        """SceneError if a box, anywhere in its along-domain, covers the character's first
        frame (its links' horizontal positions plus START_MARGIN)."""
        frame = SceneFrame.of_motion(motion)
        links = motion.link_positions(0)
        points = frame.to_scene(links[:, :2])
        lo, hi = points.min(axis=0) - START_MARGIN, points.max(axis=0) + START_MARGIN
        for box in self.boxes:
            box_lo = np.array([box.along_domain[0] - box.size[0] / 2, box.lateral - box.size[1] / 2])
            box_hi = np.array([box.along_domain[1] + box.size[0] / 2, box.lateral + box.size[1] / 2])
            if np.all(box_lo < hi) and np.all(lo < box_hi):
                raise SceneError(f"{source}: box '{box.name}' overlaps the start pose of {motion.name} (its along-domain "
                                 f"[{box.along_domain[0]:g}, {box.along_domain[1]:g}] with length {box.size[0]:g} reaches "
                                 f"the first frame's footprint, along {lo[0]:.2f}..{hi[0]:.2f} m, lateral {lo[1]:.2f}..{hi[1]:.2f} m)")


# ------------------------------------------------------------------------ the file
def _number(source, box: str, key: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise SceneError(f"{source}: box '{box}': {key} must be a finite number (m), got {value!r}")
    return float(value)


def _pair(source, box: str, key: str, value) -> tuple[float, float]:
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise SceneError(f"{source}: box '{box}': {key} must be a list of two numbers, got {value!r}")
    return _number(source, box, key, value[0]), _number(source, box, key, value[1])


def _box(source, index: int, entry) -> Box:
    if not isinstance(entry, dict):
        raise SceneError(f"{source}: box {index} must be a mapping of along, height, size, ..., got {entry!r}")
    name = entry.get("name", f"box{index}")
    if not isinstance(name, str) or not name:
        raise SceneError(f"{source}: box {index}: name must be a non-empty string, got {name!r}")
    unknown = sorted(set(map(str, entry)) - _BOX_KEYS)
    if unknown:
        raise SceneError(f"{source}: box '{name}': unknown key {unknown[0]!r} (known: {', '.join(sorted(_BOX_KEYS))})")
    for key in ("along", "height", "size"):
        if key not in entry:
            raise SceneError(f"{source}: box '{name}': missing {key}")
    along, height = _number(source, name, "along", entry["along"]), _number(source, name, "height", entry["height"])
    lateral = _number(source, name, "lateral", entry.get("lateral", 0.0))
    size = _pair(source, name, "size", entry["size"])
    if min(size) <= 0:
        raise SceneError(f"{source}: box '{name}': size must be two lengths > 0 (m), got {list(size)}")
    if height < 0:
        raise SceneError(f"{source}: box '{name}': height must be >= 0 (m), got {height:g}")
    domain = entry.get("domain", {}) or {}
    if not isinstance(domain, dict) or set(map(str, domain)) - set(FITTED):
        raise SceneError(f"{source}: box '{name}': domain must map along and/or height to [min, max], got {domain!r}")
    box = Box(name, along, height, size, lateral,
              _pair(source, name, "domain.along", domain["along"]) if "along" in domain else None,
              _pair(source, name, "domain.height", domain["height"]) if "height" in domain else None)
    for key, value, (lo, hi) in (("along", along, box.along_domain), ("height", height, box.height_domain)):
        if lo > hi:
            raise SceneError(f"{source}: box '{name}': domain.{key} [{lo:g}, {hi:g}] has min above max")
        if not lo <= value <= hi:
            raise SceneError(f"{source}: box '{name}': {key} {value:g} is outside its domain [{lo:g}, {hi:g}]")
    if box.height_domain[0] < 0:
        raise SceneError(f"{source}: box '{name}': domain.height must stay >= 0, got [{box.height_domain[0]:g}, {box.height_domain[1]:g}]")
    return box


def parse_scene(source, document) -> Scene:
    """A Scene from a parsed YAML document; `source` names it in errors."""
    if not isinstance(document, dict) or set(map(str, document)) != {"boxes"}:
        keys = sorted(map(str, document)) if isinstance(document, dict) else type(document).__name__
        raise SceneError(f"{source}: a scene file holds one key, boxes (a list of boxes), got {keys}")
    entries = document["boxes"]
    if not isinstance(entries, list) or not entries:
        raise SceneError(f"{source}: boxes must be a non-empty list, got {entries!r}")
    boxes = tuple(_box(source, i, entry) for i, entry in enumerate(entries))
    names = [b.name for b in boxes]
    duplicate = next((n for n in names if names.count(n) > 1), None)
    if duplicate is not None:
        raise SceneError(f"{source}: box name '{duplicate}' is used twice")
    return Scene(boxes)


def load_scene(path, motion=None) -> Scene:
    """Read and check a scene file; with `motion`, also that no box can cover its start pose."""
    path = Path(path)
    scene = parse_scene(path, read_yaml(path, "scene file", SceneError))
    if motion is not None:
        scene.check_start_pose(path, motion)
    return scene
