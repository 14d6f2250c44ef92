"""bend_motion: the straight walk along a turning path keeps its steps, its joints and the body's
heading relative to its travel, and turns by yaw_rate x seconds."""
import numpy as np
import pytest

from actors.character import quaternion as qn
from actors.motion.bend import bend_motion
from tests.conftest import load_clip


def _travel_yaw(motion):
    steps = np.diff(motion.root_pos[:, :2], axis=0)
    return np.unwrap(np.arctan2(steps[:, 1], steps[:, 0]))


def test_the_bent_walk_turns_at_the_rate_and_keeps_steps_joints_and_heading_to_travel():
    walk = load_clip("walk")
    rate, seconds = np.radians(30.0), 6.0
    bent = bend_motion(walk, rate, seconds)
    straight = bend_motion(walk, 0.0, seconds)
    assert not bent.loop and bent.duration == pytest.approx(seconds, abs=1.0 / walk.fps)
    np.testing.assert_allclose(bent.joint_rot, straight.joint_rot)
    np.testing.assert_allclose(np.linalg.norm(np.diff(bent.root_pos[:, :2], axis=0), axis=1),
                               np.linalg.norm(np.diff(straight.root_pos[:, :2], axis=0), axis=1), atol=1e-9)
    np.testing.assert_allclose(bent.root_pos[:, 2], straight.root_pos[:, 2])
    heading = np.unwrap(qn.heading_angle(bent.root_rot))
    turned = heading - np.unwrap(qn.heading_angle(straight.root_rot))
    np.testing.assert_allclose(turned, rate * bent.frame_times, atol=1e-6)
    # Travel direction turns by the same amount, averaged over whole gait cycles.
    cycle = int(round(walk.duration * walk.fps))
    gain = (_travel_yaw(bent) - _travel_yaw(straight))[: 4 * cycle]
    np.testing.assert_allclose(gain.reshape(4, cycle).mean(axis=1), [rate * (k + 0.5) * walk.duration for k in range(4)], atol=0.05)
    # The path closes on a circle: displacement after a full turn is small against its length.
    full = bend_motion(walk, rate, 2 * np.pi / rate)
    path = np.linalg.norm(np.diff(full.root_pos[:, :2], axis=0), axis=1).sum()
    assert np.linalg.norm(full.root_pos[-1, :2] - full.root_pos[0, :2]) < 0.1 * path


def test_a_bad_duration_is_an_error():
    with pytest.raises(ValueError, match="seconds"):
        bend_motion(load_clip("walk"), 0.5, 0.0)


def test_cli_writes_the_bent_clip_and_names_a_bad_flag(tmp_path, capsys):
    import json

    from actors.motion.formats.io import load_motion
    from services.cli import main as sfv_main

    load_clip("walk")  # skips without pybullet_data
    out = tmp_path / "walk_left.npz"
    assert sfv_main(["motion", "bend", "deepmimic:walk", "--yaw-rate", "30", "--seconds", "3", "--name", "walk_left", "--out", str(out)]) == 0
    report = json.loads(capsys.readouterr().out)
    bent = load_motion(str(out))
    assert report["name"] == bent.name == "walk_left" and not bent.loop
    straight = bend_motion(load_clip("walk"), 0.0, 3.0)
    turned = np.unwrap(qn.heading_angle(bent.root_rot)) - np.unwrap(qn.heading_angle(straight.root_rot))
    assert np.degrees(turned[-1]) == pytest.approx(90.0, abs=0.5)
    assert sfv_main(["motion", "bend", "deepmimic:walk", "--yaw-rate", "30", "--seconds", "-1", "--out", str(tmp_path / "x.npz")]) == 2
    assert "--seconds" in capsys.readouterr().err and not (tmp_path / "x.npz").exists()
