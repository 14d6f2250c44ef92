"""Which source BVH joint drives which humanoid link: rig presets, detection, and map files.

A `RigMap` names, for each humanoid target, the source joint whose *global* rotation drives it.
Targets are the humanoid's jointed links (`root`, `chest`, `neck`, `right_hip`, `right_knee`,
`right_ankle`, `right_shoulder`, `right_elbow` and the left ones) plus four optional *tips*
that only give a bone its rest direction: `right_wrist` / `left_wrist` (the forearm's end),
`right_toe` / `left_toe` (the foot's front) and `head` (the neck's end). Source joints that no
target names are simply not read: because the retargeter uses global rotations, a collar,
an extra spine joint or a finger folds into its mapped parent by construction.

Presets (`RIG_PRESETS`), matched case-insensitively after the rig's prefix, spaces in names ignored
(`Left UpLeg`, `Character1 Hips`):
- `sfv`: this project's own export (`sfv export --bvh`, `actors/motion/formats/bvh.py`).
- `cmu`: the cgspeed conversion of the CMU database (hip, abdomen, chest, neck, head, rCollar,
  rShldr, rForeArm, rHand, rButtock, rThigh, rShin, rFoot, ...).
- `cmu-original`: Carnegie Mellon's own ASF->BVH names (Hips, LowerBack, Spine, Spine1, Neck,
  Neck1, Head, RightShoulder (collar), RightArm, RightForeArm, RightHand, RHipJoint, RightUpLeg,
  RightLeg, RightFoot, RightToeBase, ...).
- `mixamo`: `mixamorig:Hips`, `mixamorig:Spine2`, `mixamorig:LeftUpLeg`, ... (any digit after
  `mixamorig`, as Mixamo numbers repeated downloads).
- `motionbuilder`: HumanIK names with a character prefix, `Character1_Hips`, ...
- `lafan1`: Ubisoft LAFAN1 (Hips, Spine, Spine1, Spine2, Neck, Head, LeftShoulder, LeftArm,
  LeftForeArm, LeftHand, LeftUpLeg, LeftLeg, LeftFoot, LeftToe); also Rokoko and Blender
  exports that use the same HumanIK names without a prefix.

Detection (`detect_rig`) tries every preset and keeps the one that maps every required
target, preferring the most targets matched and then a preset that needed a prefix. A map
file (YAML or JSON) names source joint -> humanoid target, either flat or under `joints:`:

    joints:
      pelvis: root
      spine_03: chest
      thigh_l: left_hip
      ...
"""
from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

from learner.errors import SfvError
from learner.yaml_io import read_yaml

REQUIRED_TARGETS = (
    "root", "right_hip", "right_knee", "right_ankle", "left_hip", "left_knee", "left_ankle",
    "right_shoulder", "right_elbow", "left_shoulder", "left_elbow",
)
OPTIONAL_TARGETS = ("chest", "neck", "right_wrist", "left_wrist", "right_toe", "left_toe", "head")
TARGETS = REQUIRED_TARGETS + OPTIONAL_TARGETS


@dataclass(frozen=True)
class RigMap:
    name: str
    joints: dict  # humanoid target -> source joint name (exactly as in the file)

    def source(self, target: str) -> str | None:
        return self.joints.get(target)


@dataclass(frozen=True)
class RigPreset:
    name: str
    prefix: str  # regex the source names must start with ("" = none); stripped before matching
    names: dict  # target -> tuple of accepted names (first present wins), lower case
    marks: tuple = ()  # for detection: one of these (lower case) must be present, when given

    def resolve(self, joint_names: list[str]) -> tuple[dict, list[str]]:
        """(target -> source name for every target found, required targets not found)."""
        stripped = {}
        for name in joint_names:
            match = re.match(self.prefix, name, re.IGNORECASE) if self.prefix else None
            if self.prefix and not match:
                continue
            # Exporters put spaces in names (`Left UpLeg`, `mixamorig: Hips`): matched without them.
            stripped.setdefault(re.sub(r"\s+", "", name[match.end():] if match else name).lower(), name)
        found = {}
        for target, candidates in self.names.items():
            hit = next((stripped[c] for c in candidates if c in stripped), None)
            if hit is not None:
                found[target] = hit
        return found, [t for t in REQUIRED_TARGETS if t not in found]


def _sided(right: str, left: str, parts: dict) -> dict:
    """Expand {'hip': ('{s}upleg',)} into right_/left_ targets with R/L spellings filled in."""
    out = {}
    for side, word in (("right", right), ("left", left)):
        for target, candidates in parts.items():
            out[f"{side}_{target}"] = tuple(c.format(s=word) for c in candidates)
    return out


_HUMANIK_LIMBS = _sided("right", "left", {
    "hip": ("{s}upleg",), "knee": ("{s}leg",), "ankle": ("{s}foot",), "toe": ("{s}toebase", "{s}toe"),
    "shoulder": ("{s}arm",), "elbow": ("{s}forearm",), "wrist": ("{s}hand",),
})
_HUMANIK = {"root": ("hips",), "chest": ("spine2", "spine1", "spine"), "neck": ("neck", "neck1"), "head": ("head",),
            **_HUMANIK_LIMBS}

RIG_PRESETS: tuple[RigPreset, ...] = (
    RigPreset("sfv", "", {
        "root": ("root",), "chest": ("chest",), "neck": ("neck",),
        **_sided("right", "left", {"hip": ("{s}_hip",), "knee": ("{s}_knee",), "ankle": ("{s}_ankle",),
                                   "shoulder": ("{s}_shoulder",), "elbow": ("{s}_elbow",)}),
    }),
    RigPreset("mixamo", r"mixamorig\d*:", _HUMANIK),
    RigPreset("motionbuilder", r"character\d*[_\s]", _HUMANIK),
    RigPreset("cmu", "", {
        "root": ("hip", "hips"), "chest": ("chest",), "neck": ("neck",), "head": ("head",),
        **_sided("r", "l", {"hip": ("{s}thigh",), "knee": ("{s}shin",), "ankle": ("{s}foot",),
                            "shoulder": ("{s}shldr",), "elbow": ("{s}forearm",), "wrist": ("{s}hand",)}),
    }),
    RigPreset("cmu-original", "", {
        "root": ("hips",), "chest": ("spine1", "spine"), "neck": ("neck", "neck1"), "head": ("head",),
        **_HUMANIK_LIMBS,
    }, marks=("lowerback", "lhipjoint", "rhipjoint")),
    RigPreset("lafan1", r"(?:[^:]*:)?", _HUMANIK),
)
PRESET_NAMES = tuple(p.name for p in RIG_PRESETS)


def _preset(name: str) -> RigPreset:
    for preset in RIG_PRESETS:
        if preset.name == name:
            return preset
    raise KeyError(name)


def detect_rig(joint_names: list[str], path: str | os.PathLike = "BVH") -> RigMap:
    """The preset that maps all required targets (most targets, then prefix, wins)."""
    best, best_key, closest = None, None, None
    lower = {n.lower() for n in joint_names}
    for order, preset in enumerate(RIG_PRESETS):
        if preset.marks and not lower & set(preset.marks):
            continue  # CMU's own names are HumanIK's; its LowerBack and *HipJoint tell them apart
        found, missing = preset.resolve(joint_names)
        if closest is None or len(missing) < len(closest[1]):
            closest = (preset, missing)
        if missing:
            continue
        specific = bool(preset.prefix) and preset.name != "lafan1"
        key = (len(found), bool(preset.marks), specific, -order)
        if best_key is None or key > best_key:
            best, best_key = RigMap(preset.name, found), key
    if best is None:
        preset, missing = closest
        raise SfvError(f"{path}: cannot map this rig onto the humanoid (closest preset {preset.name} lacks "
                       f"{', '.join(missing[:4])}{' ...' if len(missing) > 4 else ''}); convert it with `sfv motion convert` --rig NAME or --rig MAP.yaml")
    return best


def preset_rig(name: str, joint_names: list[str], path: str | os.PathLike = "BVH") -> RigMap:
    found, missing = _preset(name).resolve(joint_names)
    if missing:
        raise SfvError(f"{path}: rig {name} does not fit this file (no joint for {', '.join(missing)})")
    return RigMap(name, found)


def _read_map_document(map_path: Path) -> dict:
    doc = read_yaml(map_path, "rig map")  # YAML or JSON (YAML reads JSON)
    if isinstance(doc, dict) and isinstance(doc.get("joints"), dict):
        doc = doc["joints"]
    if not isinstance(doc, dict) or not all(isinstance(k, str) and isinstance(v, str) for k, v in doc.items()):
        raise SfvError(f"{map_path}: a rig map is 'source joint: humanoid target' pairs (optionally under 'joints:')")
    return doc


def load_rig_map(map_path: str | os.PathLike, joint_names: list[str], bvh_path: str | os.PathLike = "BVH") -> RigMap:
    """A map file checked against the file's joints: every source named exists, every target is known."""
    map_path = Path(map_path)
    doc = _read_map_document(map_path)
    present = set(joint_names)
    joints: dict = {}
    for source, target in doc.items():
        if target not in TARGETS:
            raise SfvError(f"{map_path}: '{source}: {target}': unknown humanoid target (known: {', '.join(TARGETS)})")
        if source not in present:
            raise SfvError(f"{map_path}: names joint '{source}', which {bvh_path} does not have")
        if target in joints:
            raise SfvError(f"{map_path}: humanoid target {target} is mapped twice ({joints[target]}, {source})")
        joints[target] = source
    missing = [t for t in REQUIRED_TARGETS if t not in joints]
    if missing:
        raise SfvError(f"{map_path}: maps no source joint to {', '.join(missing)}")
    return RigMap(map_path.stem, joints)


def resolve_rig(spec: str, joint_names: list[str], bvh_path: str | os.PathLike = "BVH") -> RigMap:
    """`auto`, a preset name, or a path to a .yaml / .yml / .json map."""
    if spec == "auto":
        return detect_rig(joint_names, bvh_path)
    if spec in PRESET_NAMES:
        return preset_rig(spec, joint_names, bvh_path)
    if Path(spec).suffix.lower() in (".yaml", ".yml", ".json"):
        return load_rig_map(spec, joint_names, bvh_path)
    raise SfvError(f"--rig {spec}: expected auto, a preset ({', '.join(PRESET_NAMES)}) or a .yaml/.json map")
