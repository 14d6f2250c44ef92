"""BVH writer and reader: round trips, the file's meaning (checked by an independent BVH
forward kinematics against the humanoid's own), and clear errors on broken files."""
from __future__ import annotations

import numpy as np
import pytest

from actors.character import quaternion as qn
from actors.motion.formats.bvh import load_bvh_motion, motion_to_bvh_text, read_bvh, write_bvh
from actors.character.kinematics import forward_kinematics
from actors.motion.reference_motion import ReferenceMotion
from actors.motion.formats.io import load_motion
from actors.character.skeleton import JOINT_NAMES, LINK_NAMES, LINKS
from learner.errors import SfvError

pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")


def rotation_error(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle (rad) of the rotation between two quaternion arrays, sign-agnostic."""
    return qn.quat_angle(qn.quat_mul(qn.quat_conj(a), b))


@pytest.fixture(scope="module")
def walk():
    return load_motion("deepmimic:walk")


@pytest.mark.parametrize("units", ["cm", "m"])
def test_walk_round_trip(walk, tmp_path, units):
    path = write_bvh(walk, tmp_path / "walk.bvh", units)
    back = load_bvh_motion(path, units)
    assert back.num_frames == walk.num_frames
    assert rotation_error(walk.joint_rot, back.joint_rot).max() < 1e-4
    assert rotation_error(walk.root_rot, back.root_rot).max() < 1e-4
    np.testing.assert_allclose(back.root_pos, walk.root_pos, atol=1e-6)
    np.testing.assert_allclose(back.frame_times, walk.frame_times, atol=1e-6)
    assert [p.name for p in tmp_path.iterdir()] == ["walk.bvh"]  # atomic: no temp file left


def test_wild_rotations_survive_including_gimbal_lock(tmp_path):
    """Random poses plus poses at the ZXY singularity (X rotation = +-90 degrees)."""
    rng = np.random.default_rng(3)
    frames = 40
    joint_rot = qn.quat_normalize(rng.normal(size=(frames, 12, 4)))
    root_rot = qn.quat_normalize(rng.normal(size=(frames, 4)))
    # Y-up x axis is Z-up x: a quarter turn about x is exactly the Euler singularity.
    joint_rot[:4] = qn.quat_from_axis_angle(np.array([np.pi / 2, 0.0, 0.0]))
    root_rot[:2] = qn.quat_from_axis_angle(np.array([-np.pi / 2, 0.0, 0.0]))
    motion = ReferenceMotion("wild", np.arange(frames) / 30.0, rng.normal(size=(frames, 3)), root_rot, joint_rot)
    back = load_bvh_motion(write_bvh(motion, tmp_path / "wild.bvh"))
    assert rotation_error(motion.joint_rot, back.joint_rot).max() < 1e-4
    assert rotation_error(motion.root_rot, back.root_rot).max() < 1e-4
    np.testing.assert_allclose(back.root_pos, motion.root_pos, atol=1e-6)


def test_uneven_clip_is_resampled_on_an_even_grid(tmp_path):
    roll = load_motion("deepmimic:roll")
    assert np.ptp(np.diff(roll.frame_times)) > 1e-3  # the clip really is uneven
    back = load_bvh_motion(write_bvh(roll, tmp_path / "roll.bvh"))
    assert np.ptp(np.diff(back.frame_times)) < 1e-6
    assert back.duration == pytest.approx(roll.duration, abs=0.02)
    expected = roll.sample(back.frame_times)
    # 1e-9 s rounding of Frame Time against a clip with near-duplicate frames: compare loosely in time
    np.testing.assert_allclose(back.root_pos, expected.root_pos, atol=1e-3)


# ------------------------------------------------------- what the file means
def _euler_zxy(angles_deg: np.ndarray) -> np.ndarray:
    """Rz(a) Rx(b) Ry(c) written out by hand (not through scipy, which the writer uses)."""
    a, b, c = np.radians(angles_deg)
    rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    rx = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    ry = np.array([[np.cos(c), 0, np.sin(c)], [0, 1, 0], [-np.sin(c), 0, np.cos(c)]])
    return rz @ rx @ ry


def _bvh_world_positions(bvh, frame: int) -> dict[str, np.ndarray]:
    """Joint positions as any BVH player computes them (Y up, file units)."""
    world_rot, world_pos = {}, {}
    for index, joint in enumerate(bvh.joints):
        values = dict(zip(joint.channels, bvh.channels_of(index)[frame]))
        local = _euler_zxy(np.array([values["Zrotation"], values["Xrotation"], values["Yrotation"]]))
        if joint.parent < 0:
            world_pos[index] = np.array([values["Xposition"], values["Yposition"], values["Zposition"]]) + joint.offset
            world_rot[index] = local
        else:
            world_pos[index] = world_pos[joint.parent] + world_rot[joint.parent] @ joint.offset
            world_rot[index] = world_rot[joint.parent] @ local
    return {bvh.joints[i].name: p for i, p in world_pos.items()}


def test_bvh_players_see_the_same_pose_as_the_humanoid(walk, tmp_path):
    bvh = read_bvh(write_bvh(walk, tmp_path / "walk.bvh", "cm"))
    link_pos, _ = forward_kinematics(walk.root_pos, walk.root_rot, walk.joint_rot)  # (T, 15, 3) Z up, metres
    for frame in (0, 11, 27):
        positions = _bvh_world_positions(bvh, frame)
        for name, p_yup_cm in positions.items():
            expected = link_pos[frame, LINK_NAMES.index(name)]
            got_zup_m = np.array([p_yup_cm[0], -p_yup_cm[2], p_yup_cm[1]]) / 100.0
            np.testing.assert_allclose(got_zup_m, expected, atol=1e-6, err_msg=f"{name} at frame {frame}")


def test_hierarchy_is_the_skeleton_in_centimetres(walk, tmp_path):
    text = motion_to_bvh_text(walk, "cm")
    assert text.startswith("HIERARCHY\nROOT root\n")
    (tmp_path / "walk.bvh").write_text(text)
    bvh = read_bvh(tmp_path / "walk.bvh")
    bvh_joints = {j.name: j for j in bvh.joints}
    assert set(bvh_joints) == {"root", *JOINT_NAMES}  # welded wrists are End Sites
    for link in LINKS[1:]:
        if link.name in bvh_joints:
            np.testing.assert_allclose(bvh_joints[link.name].offset, 100.0 * np.asarray(link.offset_yup), atol=1e-6)
    elbow = bvh_joints["right_elbow"]
    np.testing.assert_allclose(elbow.end_site, 100.0 * np.asarray(LINKS[LINK_NAMES.index("right_wrist")].offset_yup), atol=1e-6)
    assert bvh_joints["root"].channels[:3] == ("Xposition", "Yposition", "Zposition")
    assert all(j.channels[-3:] == ("Zrotation", "Xrotation", "Yrotation") for j in bvh_joints.values())
    knee = bvh.channels_of(bvh.joint_index("right_knee"))
    assert np.abs(knee[:, 1:]).max() < 1e-6 and np.abs(knee[:, 0]).max() > 10.0  # hinges turn about z only


# ------------------------------------------------------------------- errors
@pytest.mark.parametrize(
    "mutate, message",
    [
        (lambda t: t[: t.index("MOTION")], "unexpected end of file"),
        (lambda t: t.replace("CHANNELS 3 Zrotation", "CHANNELS 3 Qrotation", 1), "bad channels"),
        (lambda t: t.replace("OFFSET 0.000000 23.615100", "OFFSET 0.000000 abc", 1), "is not a number"),
        (lambda t: t.rsplit("\n", 2)[0] + "\n" + t.rsplit("\n", 2)[1][:20] + "\n", "MOTION frame 38 holds 2 values, expected 42 (the hierarchy's channels): a partial frame"),
        (lambda t: t.replace("Frame Time: ", "Frame Time: -"), "Frame Time must be positive"),
        (lambda t: t.replace("ROOT root", "ROOT pelvis"), "missing joints root"),
    ],
)
def test_broken_files_give_one_line_errors(walk, tmp_path, mutate, message):
    path = tmp_path / "broken.bvh"
    path.write_text(mutate(motion_to_bvh_text(walk)))
    with pytest.raises(SfvError) as info:
        load_bvh_motion(path)
    assert str(info.value).startswith(str(path)) and message in str(info.value) and "\n" not in str(info.value)


def test_error_names_the_line(walk, tmp_path):
    path = tmp_path / "broken.bvh"
    path.write_text(motion_to_bvh_text(walk).replace("OFFSET 0.000000 22.389400", "OFFSET 0.000000 x"))
    with pytest.raises(SfvError, match=r"line 12: OFFSET: 'x' is not a number"):
        read_bvh(path)
