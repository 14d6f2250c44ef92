"""`sfv pipeline --camera moving --scene`: bad input is one line (exit 2) before any work."""
from __future__ import annotations

import numpy as np
import pytest

from services.cli import main

BAD_BOX = "boxes:\n  - name: step\n    along: 1.0\n    height: 0.9\n    size: [0.8, 1.0]\n    domain:\n      height: [0.0, 0.5]\n"


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert err and err[-1].startswith("sfv: ")
    return err[-1]


def test_the_scene_needs_the_moving_camera_and_resume_checks_its_video_first(tmp_path, capsys):
    scene = tmp_path / "boxes.yaml"
    scene.write_text(BAD_BOX)
    assert main(["pipeline", str(tmp_path / "v.mp4"), "--out", str(tmp_path / "o"), "--scene", str(scene)]) == 2
    assert "--scene needs --camera moving" in _one_line_error(capsys)
    # --resume continues a static run too; a missing video is still one line before anything is written.
    assert main(["pipeline", str(tmp_path / "v.mp4"), "--out", str(tmp_path / "o"), "--resume"]) == 2
    assert "v.mp4: no such video file" in _one_line_error(capsys)
    assert main(["pipeline", str(tmp_path / "v.mp4"), "--out", str(tmp_path / "o"), "--resume", "--finish-only"]) == 2
    assert "--finish-only and --resume: choose one" in _one_line_error(capsys)
    assert main(["pipeline", str(tmp_path / "v.mp4"), "--out", str(tmp_path / "o"), "--camera", "moving",
                 "--body-alone", "off"]) == 2
    assert "--body-alone is for --camera static" in _one_line_error(capsys)
    assert main(["pipeline", str(tmp_path / "v.mp4"), "--out", str(tmp_path / "o"), "--samples", "1000",
                 "--body-alone-max-samples", "999"]) == 2
    assert "--body-alone-max-samples: 999 is below the stage's first budget (--samples 1000)" in _one_line_error(capsys)
    assert not (tmp_path / "o").exists()
    assert main(["pipeline", str(tmp_path / "v.mp4"), "--out", str(tmp_path / "o"), "--samples", "1000",
                 "--helped-max-samples", "500"]) == 2
    assert "--helped-max-samples: 500 is below the stage's first budget (--samples 1000)" in _one_line_error(capsys)
    assert not (tmp_path / "o").exists()


def test_a_box_outside_its_domain_stops_the_pipeline_before_the_video_is_read(tmp_path, capsys):
    pytest.importorskip("actors.arenas.scene")
    scene = tmp_path / "boxes.yaml"
    scene.write_text(BAD_BOX)
    video = tmp_path / "missing.mp4"  # never opened: the scene file is read first
    assert main(["pipeline", str(video), "--out", str(tmp_path / "o"), "--camera", "moving", "--scene", str(scene)]) == 2
    line = _one_line_error(capsys)
    assert "boxes.yaml" in line and "step" in line and "domain" in line
    assert not (tmp_path / "o").exists()


def test_not_a_video_is_one_line_in_moving_mode(tmp_path, capsys):
    pytest.importorskip("actors.envs.modes.movingcam.tracking")
    bad = tmp_path / "clip.mp4"
    bad.write_text("not a video")
    assert main(["pipeline", str(bad), "--out", str(tmp_path / "o"), "--camera", "moving"]) == 2
    assert "clip.mp4" in _one_line_error(capsys)
    assert not (tmp_path / "o").exists()


def _root_free_walk(tmp_path, keep_cues: bool):
    from actors.motion.formats.io import load_motion, save_motion

    motion = load_motion("deepmimic:walk")
    motion.loop = False
    motion.extras["root_free"] = np.array(True)
    if keep_cues:
        motion.extras["orientation_hint"] = np.zeros(motion.num_frames)
        motion.extras["contacts"] = np.ones((motion.num_frames, 2), bool)
    return save_motion(motion, tmp_path / "motion.npz")


def test_a_root_free_motion_without_cues_is_refused_before_training(tmp_path):
    pytest.importorskip("actors.envs.modes.movingcam.tracking")
    from actors.envs.imitation_env import EnvConfig
    from learner.errors import SfvError
    from services.scene_fit import scene_contract
    from services.scene_fit.stage import check_inputs

    path = _root_free_walk(tmp_path, keep_cues=False)
    with pytest.raises(SfvError, match="orientation_hint|contacts"):
        check_inputs(str(path), None, scene_contract.movingcam_env(EnvConfig(), None))


def test_a_box_over_the_start_pose_is_refused_before_training(tmp_path):
    pytest.importorskip("actors.arenas.scene")
    pytest.importorskip("actors.envs.modes.movingcam.tracking")
    from actors.envs.imitation_env import EnvConfig
    from learner.errors import SfvError
    from services.scene_fit import scene_contract
    from services.scene_fit.stage import check_inputs

    path = _root_free_walk(tmp_path, keep_cues=True)
    scene = tmp_path / "under_feet.yaml"
    scene.write_text("boxes:\n  - name: under\n    along: 0.0\n    height: 0.2\n    size: [0.5, 0.5]\n")
    with pytest.raises(SfvError, match="under.*start pose"):
        check_inputs(str(path), str(scene), scene_contract.movingcam_env(EnvConfig(), str(scene)))
