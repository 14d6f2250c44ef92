"""The G1's model files (cached by `sfv models fetch --robot g1`) and its MuJoCo model.

The files are Unitree's `g1.xml` and its STL meshes from the wheel `mjlab==1.6.0`
(`actors/character/g1_spec.py` names the source); the fetch (`services/robots/fetch.py`)
checks each against the SHA-256 digests below and caches them in
`user_cache_dir("sfv")/models/unitree_g1` (or `$SFV_G1_MODEL`), the scheme of the pose models.
Nothing is downloaded at run time: a missing or damaged cache is a one-line `SfvError`
naming the command.

`build_g1_mjcf(physics, arena)` composes the MJCF: the robot's bodies, joints and geoms as
Unitree wrote them, plus ours: every hinge's armature (reflected rotor inertia), a built-in PD
`position` actuator per hinge with kp, kd and the effort limit (`g1_spec.py`), the arena's
floor and explicit contact pairs between it and the robot's collision geoms (self-collision off,
as the humanoid's; `actors/arenas/base.py`).
"""
from __future__ import annotations

import functools
import hashlib
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
from platformdirs import user_cache_dir

from actors.arenas.flat import FlatFloor
from actors.character import g1_spec as spec
from actors.character.humanoid import PhysicsConfig
from learner.errors import SfvError

MODEL_ENV = "SFV_G1_MODEL"
FETCH_COMMAND = "sfv models fetch --robot g1"
WHEEL_DIR = "mjlab/asset_zoo/robots/unitree_g1/xmls/"
XML_FILE = "g1.xml"
LICENSE_FILE = "LICENSE"

# file in the cache -> SHA-256 of its bytes, measured on mjlab-1.6.0-py3-none-any.whl
# (the member is WHEEL_DIR + file, the licence the wheel's dist-info licence).
FILE_SHA256: dict[str, str] = {
    "g1.xml": "febdcbeffbbf84051556ae41a5ac1b43fb479a5d76bdb3f54824dbc2721c20aa",
    "assets/head_link.STL": "005fb67fbd3eff94aa8bf4a6e83238174e9f91b6721f7111594322f223724411",
    "assets/left_ankle_pitch_link.STL": "d49e3abc6f5b12e532062cd575b87b5ef40cd2a3fc18f54a1ca5bba4f773d51d",
    "assets/left_ankle_roll_link.STL": "c4092af943141d4d9f74232f3cfa345afc6565f46a077793b8ae0e68b39dc33f",
    "assets/left_elbow_link.STL": "fa752198accd104d5c4c3a01382e45165b944fbbc5acce085059223324e5bed3",
    "assets/left_hip_pitch_link.STL": "4725168105ee768ee31638ef22b53f6be2d7641bfd7cfefe803488d884776fa4",
    "assets/left_hip_roll_link.STL": "91f25922ee8a7c3152790051bebad17b4d9cd243569c38fe340285ff93a97acf",
    "assets/left_hip_yaw_link.STL": "a16d88aa6ddac8083aa7ad55ed317bea44b1fa003d314fba88965b7ed0f3b55b",
    "assets/left_knee_link.STL": "8d92b9e3d3a636761150bb8025e32514c4602b91c7028d523ee42b3e632de477",
    "assets/left_rubber_hand.STL": "cff2221a690fa69303f61fce68f2d155c1517b52efb6ca9262dd56e0bc6e70fe",
    "assets/left_shoulder_pitch_link.STL": "f0d1cfd02fcf0d42f95e678eeca33da3afbcc366ffba5c052847773ec4f31d52",
    "assets/left_shoulder_roll_link.STL": "fb9df21687773522598dc384f1a2945c7519f11cbc8bd372a49170316d6eee88",
    "assets/left_shoulder_yaw_link.STL": "1aa97e9748e924336567992181f78c7cd0652fd52a4afcca3df6b2ef6f9e712e",
    "assets/left_wrist_pitch_link.STL": "b251d8e05047f695d0f536cd78c11973cfa4e78d08cfe82759336cc3471de3a9",
    "assets/left_wrist_roll_link.STL": "edc387c9a0ba8c2237e9b296d32531426fabeb6f53e58df45c76106bca74148c",
    "assets/left_wrist_yaw_link.STL": "83f8fb3a726bf9613d65dd14f0f447cb918c3c95b3938042a0c9c09749267d3b",
    "assets/logo_link.STL": "8571a0a19bc4916fa55f91449f51d5fdefd751000054865a842449429d5f155b",
    "assets/pelvis.STL": "5ba6bbc888e630550140d3c26763f10206da8c8bd30ed886b8ede41c61f57a31",
    "assets/pelvis_contour_link.STL": "5cc5c2c7a312329e3feeb2b03d3fc09fc29705bd01864f6767e51be959662420",
    "assets/right_ankle_pitch_link.STL": "15be426539ec1be70246d4d82a168806db64a41301af8b35c197a33348c787a9",
    "assets/right_ankle_roll_link.STL": "4b66222ea56653e627711b56d0a8949b4920da5df091da0ceb343f54e884e3a5",
    "assets/right_elbow_link.STL": "1be925d7aa268bb8fddf5362b9173066890c7d32092c05638608126e59d1e2ab",
    "assets/right_hip_pitch_link.STL": "e4f3c99d7f4a7d34eadbef9461fc66e3486cb5442db1ec50c86317d459f1a9c6",
    "assets/right_hip_roll_link.STL": "4c254ef66a356f492947f360dd931965477b631e3fcc841f91ccc46d945d54f6",
    "assets/right_hip_yaw_link.STL": "e479c2936ca2057e9eb2f7dff6c189b7419d7b8484dea0b298cbb36a2a6aa668",
    "assets/right_knee_link.STL": "63c4008449c9bbe701a6e2b557b7a252e90cf3a5abcf54cee46862b9a69f8ec8",
    "assets/right_rubber_hand.STL": "99533b778bca6246144fa511bb9d4e555e075c641f2a0251e04372869cd99d67",
    "assets/right_shoulder_pitch_link.STL": "24cdb387e0128dfe602770a81c56cdce3a0181d34d039a11d1aaf8819b7b8c02",
    "assets/right_shoulder_roll_link.STL": "962b97c48f9ce9e8399f45dd9522e0865d19aa9fd299406b2d475a8fc4a53e81",
    "assets/right_shoulder_yaw_link.STL": "a0b76489271da0c72461a344c9ffb0f0c6e64f019ea5014c1624886c442a2fe5",
    "assets/right_wrist_pitch_link.STL": "d22f8f3b3127f15a63e5be1ee273cd5075786c3142f1c3d9f76cbf43d2a26477",
    "assets/right_wrist_roll_link.STL": "a7ee9212ff5b94d6cb7f52bb1bbf3f352194d5b598acff74f4c77d340c5b344f",
    "assets/right_wrist_yaw_link.STL": "bc9dece2d12509707e0057ba2e48df8f3d56db0c79410212963a25e8a50f61a6",
    "assets/torso_link_rev_1_0.STL": "11ddb46f2098efbbd8816b1d65893632d8e78be936376c7cdcd6771899ccc723",
    "assets/waist_roll_link_rev_1_0.STL": "b67c347a05abc3e8ddae600d98a082bee273bb39f8e651647708b0a7140a8a97",
    "assets/waist_yaw_link_rev_1_0.STL": "ec6db442b11f25eed898b5add07940c85d804f300de24dcbd264ccd8be7d554c",
    LICENSE_FILE: "8ca04d9dbbccd20f0f1842fb33e13949f9e57064b150dad36af8e7a751ca3321",
}
LICENSE_MEMBER = "mjlab-1.6.0.dist-info/licenses/LICENSE"


def wheel_member(file_name: str) -> str:
    """The path inside the mjlab wheel of a cached file."""
    return LICENSE_MEMBER if file_name == LICENSE_FILE else WHEEL_DIR + file_name


def default_model_dir() -> Path:
    """$SFV_G1_MODEL if set, else the user cache (`user_cache_dir("sfv")/models/unitree_g1`)."""
    override = os.environ.get(MODEL_ENV)
    if override:
        return Path(override).expanduser()
    return Path(user_cache_dir("sfv")) / "models" / "unitree_g1"


def sha256_file(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def damaged_files(directory: Path, files: dict[str, str] | None = None) -> list[str]:
    """Cached files that are missing or differ from their pinned digest (empty: the cache is good)."""
    files = FILE_SHA256 if files is None else files
    bad = []
    for name, expected in files.items():
        path = directory / name
        if not path.is_file() or sha256_file(path) != expected:
            bad.append(name)
    return bad


@functools.lru_cache(maxsize=8)
def _checked_dir(directory: str, files: tuple[tuple[str, str], ...]) -> Path:
    path = Path(directory)
    if not (path / XML_FILE).is_file():
        raise SfvError(f"{path / XML_FILE}: the G1 model is not cached; run `{FETCH_COMMAND}` (or set {MODEL_ENV})")
    bad = damaged_files(path, dict(files))
    if bad:
        more = f" and {len(bad) - 1} more" if len(bad) > 1 else ""
        raise SfvError(f"{path / bad[0]}{more}: missing or not the pinned SHA-256; run `{FETCH_COMMAND} --force`")
    return path


def model_dir(directory: str | Path | None = None) -> Path:
    """The checked cache directory of the G1 files (SfvError in one line when absent or damaged)."""
    directory = Path(directory).expanduser() if directory is not None else default_model_dir()
    return _checked_dir(str(directory.resolve()), tuple(sorted(FILE_SHA256.items())))


def model_available(directory: str | Path | None = None) -> bool:
    try:
        model_dir(directory)
    except SfvError:
        return False
    return True


# ------------------------------------------------------------------------------ MJCF
def _fmt(values) -> str:
    return " ".join(f"{x:.6g}" for x in np.ravel(values))


def collision_geom_names(root: ET.Element) -> list[str]:
    return [g.get("name") for g in root.iter("geom") if (g.get("name") or "").endswith("_collision")]


def build_g1_mjcf(physics=None, arena=None, directory: str | Path | None = None) -> str:
    """MJCF text of the G1 in an arena (a flat floor by default) with our actuators.

    `physics` is a `PhysicsConfig` (`actors/character/humanoid.py`: physics rate, friction,
    joint damping; its armature is the humanoid's and is not used: the G1's comes from its
    motors). Mesh paths are absolute, so the text compiles from anywhere.
    """
    physics = PhysicsConfig() if physics is None else physics
    arena = FlatFloor() if arena is None else arena
    folder = model_dir(directory)
    root = ET.parse(folder / XML_FILE).getroot()
    root.set("model", "sfv_g1")
    compiler = root.find("compiler")
    compiler.set("meshdir", str(folder / "assets"))
    option = ET.Element("option", timestep=f"{1.0 / physics.physics_hz:.8g}", integrator="implicitfast")
    root.insert(list(root).index(compiler) + 1, option)
    # Self-collision off and no broad phase: the arena lists its pairs with our collision geoms.
    for default in root.iter("default"):
        if default.get("class") == "collision":
            default.find("geom").set("contype", "0")
            default.find("geom").set("conaffinity", "0")
    joints = {j.get("name"): j for j in root.iter("joint")}
    for i, name in enumerate(spec.JOINT_NAMES):
        if name not in joints:
            raise SfvError(f"{folder / XML_FILE}: no joint {name}; run `{FETCH_COMMAND} --force`")
        joints[name].set("armature", f"{spec.ARMATURE[i]:.6g}")
        joints[name].set("damping", f"{physics.joint_damping:.6g}")
    fragments = {
        "asset": arena.assets_xml(),
        "worldbody": arena.worldbody_xml(),
        "contact": arena.contact_pairs_xml([(g, g) for g in collision_geom_names(root)], physics.friction),
        "actuator": "\n".join(
            f'<position name="{name.replace("_joint", "")}" joint="{name}" kp="{spec.KP[i]:.6g}" kv="{spec.KD[i]:.6g}" '
            f'forcerange="{_fmt((-spec.EFFORT_LIMITS[i], spec.EFFORT_LIMITS[i]))}"/>' for i, name in enumerate(spec.JOINT_NAMES)),
    }
    props = getattr(arena, "props_xml", None)
    for tag, text in fragments.items():
        section = root.find(tag)
        if section is None:
            section = ET.SubElement(root, tag)
        children = list(ET.fromstring(f"<x>{text}</x>"))
        if tag == "worldbody":
            for k, child in enumerate(children):
                section.insert(k, child)
            if props is not None and props():
                section.extend(list(ET.fromstring(f"<x>{props()}</x>")))
        else:
            section.extend(children)
    visual = ET.Element("visual")
    ET.SubElement(visual, "global", offwidth="1280", offheight="720")
    root.insert(list(root).index(option) + 1, visual)
    return ET.tostring(root, encoding="unicode")


def _drop_meshes(root: ET.Element) -> None:
    """Remove the visual meshes (bodies keep their explicit inertials, so the kinematics and
    masses are unchanged; compiling the 19 MB of STL costs 10-30 s on these machines)."""
    for parent in list(root.iter()):
        for child in list(parent):
            if child.tag == "mesh" or (child.tag == "geom" and child.get("mesh")):
                parent.remove(child)


@functools.lru_cache(maxsize=4)
def _kinematic_xml(folder: str) -> str:
    root = ET.parse(Path(folder) / XML_FILE).getroot()
    _drop_meshes(root)
    return ET.tostring(root, encoding="unicode")


def kinematic_model(directory: str | Path | None = None) -> mujoco.MjModel:
    """The robot alone (no floor, no actuators, no visual meshes): for kinematics and IK."""
    return mujoco.MjModel.from_xml_string(_kinematic_xml(str(model_dir(directory))))
