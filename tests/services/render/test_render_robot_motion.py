"""`sfv render-motion CLIP_g1.npz`: the source humanoid beside the G1 playing the robot motion."""
from __future__ import annotations

import numpy as np
import pytest

from actors.character import g1_model
from services.cli import main

pytestmark = pytest.mark.skipif(not g1_model.model_available(), reason="G1 model not cached (sfv models fetch --robot g1)")


def test_the_g1_is_drawn_beside_its_source(walk_clip, tmp_path, capsys):
    imageio = pytest.importorskip("imageio.v2")
    robot, video = tmp_path / "walk_g1.npz", tmp_path / "side.mp4"
    assert main(["motion", "convert", "deepmimic:walk", "--character", "g1", "--fps", "10", "--out", str(robot)]) == 0
    capsys.readouterr()
    assert main(["render-motion", str(robot), "--out", str(video), "--height", "160"]) == 0
    assert "13 frames rendered beside its source deepmimic:walk" in capsys.readouterr().out  # 1.27 s at 10 fps
    frame = imageio.get_reader(video).get_data(6).astype(int)
    assert frame.shape == (160, 212, 3)
    lower = frame[80:]  # below the horizon: floor and legs (the sky is black)
    dark = lambda pixels: (pixels < 70).all(axis=-1)  # noqa: E731  (the G1's black parts: pelvis, feet, hands)
    robot_dark = np.argwhere(dark(lower[:, 106:]))
    assert len(robot_dark) > 20
    assert 25 < robot_dark[:, 1].mean() < 80  # the camera follows the robot: it is near the panel's middle


def test_a_robot_motion_with_a_video_is_refused_in_one_line(walk_clip, tmp_path, capsys):
    from actors.character import g1_spec
    from actors.motion.robot_motion import RobotMotion, save_robot_motion

    frames = 3
    motion = RobotMotion("g1", "still", "deepmimic:walk", 30.0, False, g1_spec.JOINT_NAMES, np.tile([0, 0, 0.8], (frames, 1)),
                         np.tile([1.0, 0, 0, 0], (frames, 1)), np.zeros((frames, 29)))
    path = save_robot_motion(motion, tmp_path / "still_g1.npz")
    assert main(["render-motion", str(path), "--video", str(tmp_path / "clip.mp4"), "--out", str(tmp_path / "x.mp4")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not a video or BVH" in err
    assert not (tmp_path / "x.mp4").exists()
