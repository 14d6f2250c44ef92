"""`sfv train --motion CLIP.bvh`: a foreign rig's clip goes straight into training and evaluation."""
from __future__ import annotations

import json

from services.cli import main
from tests.foreign_rig import MIXAMO_NAMES, foreign_bvh_text


def test_train_and_eval_on_a_foreign_bvh(walk_clip, tmp_path, capsys):
    bvh = tmp_path / "walk.bvh"
    bvh.write_text(foreign_bvh_text(walk_clip, MIXAMO_NAMES, "y_up"))
    out = tmp_path / "run"
    assert main(["train", "--serial", "--workers", "1", "--envs-per-worker", "4", "--init", "fsi", "--samples", "128",
                 "--batch-size", "128", "--motion", str(bvh), "--out", str(out), "--quiet"]) == 0
    assert json.loads(capsys.readouterr().out.strip().splitlines()[-1])["samples"] == 128
    assert json.loads((out / "config.json").read_text())["motion"] == str(bvh)
    assert main(["eval", str(out), "--episodes", "1"]) == 0  # eval reads the BVH again from the run's config
    result = json.loads(capsys.readouterr().out)
    assert result["motion"] == "walk" and result["episodes"] == 1
