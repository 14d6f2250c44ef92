"""Real-world BVH: what exporters write converts (each quirk reported in the JSON) and trains.

The files are the walk written through a foreign rig (`tests/foreign_rig.py`, Mixamo names),
then given one exporter quirk each. Only a partial frame, a non-number or a CHANNELS line
whose count is not what it lists is an error (`tests/test_bvh_import_errors.py`).
"""
from __future__ import annotations

import json
import re

import numpy as np
import pytest

from actors.motion.formats.io import load_motion
from services.cli import main
from tests.foreign_rig import MIXAMO_NAMES, foreign_bvh_text

DECLARED = 39  # the walk's frames, as the clean file declares them


def _frame_lines(text: str) -> tuple[str, list[str]]:
    head, frames = text.split("Frame Time:", 1)
    first, *rows = frames.split("\n")
    return head + "Frame Time:" + first + "\n", [row for row in rows if row.strip()]


def _extra_frame(text: str) -> str:
    head, rows = _frame_lines(text)
    return head + "\n".join(rows + [rows[-1]]) + "\n"


def _tabs(text: str) -> str:
    return "\n".join(re.sub(r"^ +", lambda m: "\t" * (len(m.group()) // 2), line).replace(" ", "\t")
                     if not line.startswith("Frame") else line for line in text.split("\n"))


def _no_end_sites(text: str) -> str:
    return re.sub(r"\n *End Site\n *\{\n *OFFSET[^\n]*\n *\}", "", text)


# (name, mutation, the quirk the JSON reports, frames read)
QUIRKS = [
    ("more frames than declared", _extra_frame, "frame_count", DECLARED + 1),
    ("fewer frames than declared", lambda t: t.replace(f"Frames: {DECLARED}", f"Frames: {DECLARED + 5}"), "frame_count", DECLARED),
    ("crlf", lambda t: t.replace("\n", "\r\n"), "crlf_line_ends", DECLARED),
    ("tabs", _tabs, "tabs", DECLARED),
    ("blank trailing lines", lambda t: t + "\n\n  \n", "blank_lines", DECLARED),
    ("frame time spacing", lambda t: t.replace("Frame Time: ", "Frame Time:\t").replace("Frames: ", "Frames:"),
     "motion_header_spacing", DECLARED),
    ("names with spaces", lambda t: t.replace("mixamorig:", "Character1 "), "joint_names_with_spaces", DECLARED),
    ("missing end sites", _no_end_sites, "leaf_joints_without_end_site", DECLARED),
    ("byte-order mark", lambda t: "\ufeff" + t, "utf8_byte_order_mark", DECLARED),
]
ALL_AT_ONCE = ("frame_count", "crlf_line_ends", "tabs", "blank_lines", "motion_header_spacing", "joint_names_with_spaces",
               "leaf_joints_without_end_site")


@pytest.fixture(scope="module")
def clean_text(walk_clip):
    return foreign_bvh_text(walk_clip, MIXAMO_NAMES, "z_up")


def _convert(tmp_path, text: str, capsys, name: str = "clip"):
    path = tmp_path / f"{name}.bvh"
    path.write_bytes(text.encode("utf-8"))
    out = tmp_path / f"{name}.npz"
    assert main(["motion", "convert", str(path), "--out", str(out)]) == 0, capsys.readouterr().err
    return json.loads(capsys.readouterr().out.strip().splitlines()[-1]), load_motion(str(out))


@pytest.fixture(scope="module")
def clean_motion(clean_text, tmp_path_factory):
    path = tmp_path_factory.mktemp("clean") / "clean.bvh"
    path.write_text(clean_text)
    return load_motion(str(path))


def _all_quirks(text: str) -> str:
    text = _no_end_sites(_extra_frame(text)).replace("mixamorig:", "Character1 ")
    text = _tabs(text.replace("Frame Time: ", "Frame Time:  "))
    return text.replace("\n", "\r\n") + "\r\n\r\n"


@pytest.mark.parametrize("what, mutate, quirk, frames", QUIRKS, ids=[q[0] for q in QUIRKS])
def test_each_quirk_converts_and_is_reported(clean_text, clean_motion, tmp_path, capsys, what, mutate, quirk, frames):
    report, motion = _convert(tmp_path, mutate(clean_text), capsys)
    assert quirk in report["bvh"]["quirks"], report["bvh"]
    assert report["bvh"]["frames_read"] == frames == motion.num_frames
    assert report["bvh"]["frames_declared"] == (DECLARED + 5 if what == "fewer frames than declared" else DECLARED)
    shared = min(frames, clean_motion.num_frames)
    np.testing.assert_allclose(motion.joint_rot[:shared], clean_motion.joint_rot[:shared], atol=1e-6)
    np.testing.assert_allclose(motion.root_pos[:shared], clean_motion.root_pos[:shared], atol=1e-6)


def test_a_clean_file_reports_no_quirk(clean_text, tmp_path, capsys):
    report, _ = _convert(tmp_path, clean_text, capsys)
    assert report["bvh"] == {"frames_declared": DECLARED, "frames_read": DECLARED, "quirks": {}}


def test_motionbuilder_and_mixamo_names_are_detected(clean_text, tmp_path, capsys):
    underscored, _ = _convert(tmp_path, clean_text.replace("mixamorig:", "Character1_"), capsys, "mb")
    assert underscored["retarget"]["rig"] == "motionbuilder"
    colons, _ = _convert(tmp_path, clean_text, capsys, "mixamo")
    assert colons["retarget"]["rig"] == "mixamo"


@pytest.mark.integration
def test_a_file_with_every_quirk_trains(clean_text, tmp_path, capsys):
    path = tmp_path / "quirky.bvh"
    path.write_bytes(_all_quirks(clean_text).encode("utf-8"))
    report, _ = _convert(tmp_path, path.read_bytes().decode("utf-8"), capsys, "quirky_copy")
    assert set(ALL_AT_ONCE) <= set(report["bvh"]["quirks"]), report["bvh"]
    run = tmp_path / "run"
    assert main(["train", "--motion", str(path), "--runner", "in_process", "--workers", "1", "--envs-per-worker", "2",
                 "--samples", "64", "--batch-size", "64", "--eval-every", "0", "--quiet", "--out", str(run)]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out.strip().splitlines()[-1])["samples"] == 64
    assert f"{DECLARED} declared, {DECLARED + 1} whole frames read" in captured.err  # one line says what was read
    assert (run / "config.json").exists()
