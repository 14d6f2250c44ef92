"""`sfv motion check` on a robot motion file: its own robot plays it back (reward ~1)."""
from __future__ import annotations

import json

import pytest

from actors.character import g1_model
from services.cli import main as sfv_main

pytestmark = pytest.mark.skipif(not g1_model.model_available(), reason="G1 model not cached (sfv models fetch --robot g1)")


def test_a_g1_motion_file_is_checked_on_the_g1_and_plays_back_at_one(tmp_path, capsys):
    pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")
    out = tmp_path / "walk_g1.npz"
    assert sfv_main(["motion", "convert", "deepmimic:walk", "--character", "g1", "--out", str(out)]) == 0
    capsys.readouterr()
    assert sfv_main(["motion", "check", str(out)]) == 0
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert report["character"] == "g1" and report["joints"] == 29
    assert report["playback_reward"] > 0.99
