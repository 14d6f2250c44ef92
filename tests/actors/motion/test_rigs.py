"""Rig presets and detection from joint names, and rig map files."""
from __future__ import annotations

import pytest

from actors.motion.formats.rigs import detect_rig, load_rig_map, resolve_rig
from learner.errors import SfvError

SIDES = (("Left", "l"), ("Right", "r"))
CGSPEED_CMU = ["hip", "abdomen", "chest", "neck", "head", "leftEye", "rightEye"] + [
    f"{s}{part}" for _, s in SIDES for part in ("Collar", "Shldr", "ForeArm", "Hand", "Thumb1", "Buttock", "Thigh", "Shin", "Foot")]
CARNEGIE_CMU = ["Hips", "LowerBack", "Spine", "Spine1", "Neck", "Neck1", "Head", "LHipJoint", "RHipJoint"] + [
    f"{S}{part}" for S, _ in SIDES for part in ("Shoulder", "Arm", "ForeArm", "Hand", "FingerBase", "HandIndex1", "UpLeg", "Leg", "Foot", "ToeBase")]
HUMANIK = ["Hips", "Spine", "Spine1", "Spine2", "Neck", "Head"] + [
    f"{S}{part}" for S, _ in SIDES for part in ("Shoulder", "Arm", "ForeArm", "Hand", "UpLeg", "Leg", "Foot", "ToeBase")]
LAFAN1 = ["Hips", "Spine", "Spine1", "Spine2", "Neck", "Head"] + [
    f"{S}{part}" for S, _ in SIDES for part in ("Shoulder", "Arm", "ForeArm", "Hand", "UpLeg", "Leg", "Foot", "Toe")]
SFV = ["root", "chest", "neck"] + [f"{side}_{j}" for side in ("right", "left") for j in ("hip", "knee", "ankle", "shoulder", "elbow")]


@pytest.mark.parametrize("names, rig, chest, right_shoulder, right_toe", [
    (CGSPEED_CMU, "cmu", "chest", "rShldr", None),
    (CARNEGIE_CMU, "cmu-original", "Spine1", "RightArm", "RightToeBase"),
    (["mixamorig:" + n for n in HUMANIK], "mixamo", "mixamorig:Spine2", "mixamorig:RightArm", "mixamorig:RightToeBase"),
    (["mixamorig7:" + n for n in HUMANIK], "mixamo", "mixamorig7:Spine2", "mixamorig7:RightArm", "mixamorig7:RightToeBase"),
    (["Character1_" + n for n in HUMANIK], "motionbuilder", "Character1_Spine2", "Character1_RightArm", "Character1_RightToeBase"),
    (LAFAN1, "lafan1", "Spine2", "RightArm", "RightToe"),
    (SFV, "sfv", "chest", "right_shoulder", None),
])
def test_presets_are_detected(names, rig, chest, right_shoulder, right_toe):
    found = detect_rig(names)
    assert found.name == rig
    assert found.source("chest") == chest and found.source("right_shoulder") == right_shoulder
    assert found.source("right_toe") == right_toe
    assert resolve_rig(rig, names).joints == found.joints


def test_unmappable_rig_names_the_file_and_the_gap():
    names = [n.replace("UpLeg", "Thigh") for n in LAFAN1]
    with pytest.raises(SfvError, match=r"^clip.bvh: cannot map this rig .*lacks right_hip, left_hip"):
        detect_rig(names, "clip.bvh")
    with pytest.raises(SfvError, match=r"rig mixamo does not fit"):
        resolve_rig("mixamo", LAFAN1, "clip.bvh")
    with pytest.raises(SfvError, match=r"--rig banana: expected auto"):
        resolve_rig("banana", LAFAN1)


def _lafan_map() -> dict:
    return {"Hips": "root", "Spine2": "chest", **{f"{S}{part}": f"{side}_{t}" for S, side in (("Left", "left"), ("Right", "right"))
            for part, t in (("UpLeg", "hip"), ("Leg", "knee"), ("Foot", "ankle"), ("Arm", "shoulder"), ("ForeArm", "elbow"))}}


@pytest.mark.parametrize("edit, message", [
    (lambda m: {**m, "Pelvis": "neck"}, "names joint 'Pelvis', which clip.bvh does not have"),
    (lambda m: {**m, "Neck": "nose"}, "unknown humanoid target"),
    (lambda m: {k: v for k, v in m.items() if v != "left_knee"}, "maps no source joint to left_knee"),
    (lambda m: {**m, "Spine1": "chest"}, "mapped twice"),
])
def test_map_file_errors(tmp_path, edit, message):
    path = tmp_path / "rig.yaml"
    path.write_text("".join(f"{k}: {v}\n" for k, v in edit(_lafan_map()).items()))
    with pytest.raises(SfvError, match=message) as info:
        load_rig_map(path, LAFAN1, "clip.bvh")
    assert str(info.value).startswith(str(path))


def test_map_file_loads(tmp_path):
    path = tmp_path / "rig.yml"
    path.write_text("joints:\n" + "".join(f"  {k}: {v}\n" for k, v in _lafan_map().items()))
    rig = load_rig_map(path, LAFAN1)
    assert rig.source("chest") == "Spine2" and rig.source("left_elbow") == "LeftForeArm" and rig.source("neck") is None
