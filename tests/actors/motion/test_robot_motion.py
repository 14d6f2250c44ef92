"""The robot motion file (`sfv-robot-motion-1`): round trip and one-line errors (no model needed)."""
import numpy as np
import pytest

from actors.character import g1_spec
from actors.motion.reference_motion import MotionFormatError
from actors.motion.robot_motion import FORMAT, RobotMotion, load_robot_motion, save_robot_motion


def _motion(frames: int = 5) -> RobotMotion:
    joints = np.tile(g1_spec.standing_joint_angles(), (frames, 1))
    joints[:, 3] += np.linspace(0.0, 0.3, frames)  # the left knee bends
    return RobotMotion(character="g1", name="walk_g1", source="deepmimic:walk", fps=30.0, loop=True,
                       joint_names=g1_spec.JOINT_NAMES, root_pos=np.tile([0.0, 0.0, 0.76], (frames, 1)),
                       root_quat=np.tile([1.0, 0.0, 0.0, 0.0], (frames, 1)), joint_pos=joints,
                       contacts=np.ones((frames, 2), dtype=bool))


def test_round_trip(tmp_path):
    motion = _motion()
    path = save_robot_motion(motion, tmp_path / "walk_g1.npz")
    back = load_robot_motion(path, "g1")
    assert (back.name, back.source, back.fps, back.loop, back.joint_names) == \
        ("walk_g1", "deepmimic:walk", 30.0, True, g1_spec.JOINT_NAMES)
    assert np.array_equal(back.joint_pos, motion.joint_pos) and np.array_equal(back.contacts, motion.contacts)
    assert back.qpos().shape == (5, 36) and back.duration == pytest.approx(4 / 30)


def _rewrite(path, **changes):
    with np.load(path) as data:
        arrays = {key: data[key] for key in data.files}
    arrays.update(changes)
    for key in [k for k, v in changes.items() if v is None]:
        arrays.pop(key)
    np.savez(path, **arrays)


@pytest.mark.parametrize("changes, fault", [
    ({"format": np.array("sfv-motion-1")}, "is not sfv-robot-motion-1"),
    ({"joint_pos": None}, "missing 'joint_pos'"),
    ({"root_quat": np.tile([1.0, 0.0, 0.0, 0.0], (4, 1))}, "root_quat has shape (4, 4), expected (5, 4)"),
    ({"root_quat": np.tile([2.0, 0.0, 0.0, 0.0], (5, 1))}, "root_quat of frame 0 has norm 2.0000"),
    ({"fps": np.array(-1.0)}, "fps -1.0 is not a positive number"),
    ({"joint_names": np.array(g1_spec.JOINT_NAMES[::-1])}, "joint_names are not the g1's 29 joints"),
])
def test_faults_are_one_line_errors_naming_the_file(tmp_path, changes, fault):
    path = save_robot_motion(_motion(), tmp_path / "bad.npz")
    _rewrite(path, **changes)
    with pytest.raises(MotionFormatError) as error:
        load_robot_motion(path)
    message = str(error.value)
    assert "\n" not in message and str(path) in message and fault in message, message


def test_angles_outside_the_robot_limits_are_refused(tmp_path):
    motion = _motion()
    motion.joint_pos[2, g1_spec.JOINT_NAMES.index("left_ankle_roll_joint")] = 0.5
    path = tmp_path / "over.npz"
    save_robot_motion(motion, path)  # the writer checks shapes only; the loader knows the robot
    with pytest.raises(MotionFormatError, match="left_ankle_roll_joint at frame 2 is 0.5000 rad, outside its limits"):
        load_robot_motion(path)


def test_angles_a_soft_limit_past_are_clipped_and_reported(tmp_path, caplog):
    """A simulated rollout's joints pass MuJoCo's soft limits by a few hundredths of a radian."""
    motion = _motion()
    waist = g1_spec.JOINT_NAMES.index("waist_roll_joint")
    motion.joint_pos[3, waist] = 0.5379  # 0.018 past 0.52
    path = save_robot_motion(motion, tmp_path / "rollout_g1.npz")
    with caplog.at_level("WARNING", logger="sfv.motion"):
        back = load_robot_motion(path, "g1")
    assert back.joint_pos[3, waist] == pytest.approx(0.52)
    assert np.array_equal(np.delete(back.joint_pos, waist, axis=1), np.delete(motion.joint_pos, waist, axis=1))
    (record,) = caplog.records
    assert "1 joint angle(s) past their limits by up to 0.018 rad (waist_roll_joint at frame 3" in record.getMessage()


def test_a_humanoid_motion_or_another_robot_is_refused(tmp_path, walk_clip):
    from actors.motion.formats.io import save_motion

    humanoid = save_motion(walk_clip, tmp_path / "walk.npz")
    with pytest.raises(MotionFormatError, match="format 'sfv-motion-1' is not " + FORMAT):
        load_robot_motion(humanoid)
    path = save_robot_motion(_motion(), tmp_path / "g1.npz")
    with pytest.raises(MotionFormatError, match="a motion for 'g1', not for 'h1'"):
        load_robot_motion(path, "h1")
    with pytest.raises(MotionFormatError, match="no such file"):
        load_robot_motion(tmp_path / "absent.npz")


def test_convert_without_the_cached_model_is_a_one_line_hint(tmp_path, monkeypatch, capsys, walk_clip):
    from services.cli import main

    monkeypatch.setenv("SFV_G1_MODEL", str(tmp_path / "no-model"))
    out = tmp_path / "walk_g1.npz"
    assert main(["motion", "convert", "deepmimic:walk", "--character", "g1", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "run `sfv models fetch --robot g1`" in err
    assert not out.exists()
