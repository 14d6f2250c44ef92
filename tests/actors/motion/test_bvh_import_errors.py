"""Broken BVH files through the command line: one line naming the file and the fault, exit 2,
nothing written."""
from __future__ import annotations

import re

import pytest

from services.cli import main
from tests.foreign_rig import MIXAMO_NAMES, foreign_bvh_text


def _cut_last_frame(text: str) -> str:
    """A partial last frame: its line cut after a few values (a whole frame missing is tolerated)."""
    head, last = text.rstrip("\n").rsplit("\n", 1)
    return head + "\n" + " ".join(last.split()[:5]) + "\n"


def _value_in_frame(row: int, column: int, value: str):
    def mutate(text: str) -> str:
        head, frames = text.split("Frame Time:", 1)
        lines = frames.split("\n")
        values = lines[row].split()
        values[column] = value
        lines[row] = " ".join(values)
        return head + "Frame Time:" + "\n".join(lines)

    return mutate


BROKEN = [
    ("truncated hierarchy", lambda t: t[: t.index("mixamorig:LeftUpLeg") + 40], "unexpected end of file"),
    ("truncated motion", _cut_last_frame, "a partial frame"),
    ("channel count", lambda t: t.replace("CHANNELS 3 Zrotation Yrotation Xrotation", "CHANNELS 2 Zrotation Yrotation", 1), "a partial frame"),
    ("channels listed", lambda t: t.replace("CHANNELS 3 Zrotation Yrotation Xrotation", "CHANNELS 3 Zrotation Yrotation", 1), "CHANNELS says 3 but lists 2"),
    ("not a number", _value_in_frame(3, 4, "abc"), "'abc' is not a number"),
    ("bad channel", lambda t: t.replace("CHANNELS 3 Zrotation", "CHANNELS 3 Wrotation", 1), "bad channels"),
    ("nan", _value_in_frame(5, 7, "nan"), "holds NaN"),
    ("garbled frame time", lambda t: t.replace("Frame Time: ", "Frame Time: 0*"), "is not a number"),
    ("zero frame time", lambda t: re.sub(r"Frame Time: \S+", "Frame Time: 0.0", t), "Frame Time must be positive"),
    ("negative frame time", lambda t: t.replace("Frame Time: ", "Frame Time: -"), "Frame Time must be positive"),
    ("one frame", lambda t: t.replace("Frames: 39", "Frames: 1").split("Frame Time:")[0] + "Frame Time:" + t.split("Frame Time:")[1].split("\n", 2)[0] + "\n" + t.split("Frame Time:")[1].split("\n", 2)[1] + "\n", "at least 2 frames"),
    ("unmappable", lambda t: t.replace("mixamorig:", "bone_"), "cannot map this rig"),
]


@pytest.fixture(scope="module")
def foreign_text(walk_clip):
    return foreign_bvh_text(walk_clip, MIXAMO_NAMES, "z_up")


@pytest.mark.parametrize("what, mutate, message", BROKEN, ids=[b[0] for b in BROKEN])
@pytest.mark.parametrize("command", ["convert", "check"])
def test_broken_bvh_exits_2_with_one_line(foreign_text, tmp_path, capsys, what, mutate, message, command):
    path = tmp_path / "clip.bvh"
    path.write_text(mutate(foreign_text))
    out = tmp_path / "clip.npz"
    argv = ["motion", "convert", str(path), "--out", str(out)] if command == "convert" else ["motion", "check", str(path)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"sfv: {path}") and message in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["clip.bvh"]


def test_map_naming_an_absent_joint(foreign_text, tmp_path, capsys):
    path = tmp_path / "clip.bvh"
    path.write_text(foreign_text)
    rig = tmp_path / "rig.yaml"
    rig.write_text("mixamorig:Hips: root\nmixamorig:Pelvis: chest\n")
    out = tmp_path / "clip.npz"
    assert main(["motion", "convert", str(path), "--out", str(out), "--rig", str(rig)]) == 2
    err = capsys.readouterr().err
    assert err == f"sfv: {rig}: names joint 'mixamorig:Pelvis', which {path} does not have\n"
    assert not out.exists()


def test_bvh_flags_on_other_formats_are_refused(tmp_path, capsys):
    out = tmp_path / "w.npz"
    assert main(["motion", "convert", "deepmimic:walk", "--out", str(out), "--rig", "cmu"]) == 2
    assert "apply to BVH input only" in capsys.readouterr().err and not out.exists()
