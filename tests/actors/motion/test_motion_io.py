"""Loading, saving and sampling reference motions; every malformed file is a one-line error."""
import json
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from actors.character import quaternion as qn
from actors.character.humanoid3d import Humanoid
from actors.motion.reference_motion import MotionFormatError, ReferenceMotion
from actors.motion.formats.io import DEEPMIMIC_CLIPS, DEEPMIMIC_COLUMNS, load_motion, save_motion
from actors.character.skeleton import JOINT_IS_SPHERICAL, NUM_JOINTS, yup_to_zup
from actors.character.state import StateLayout
from services.cli import main as sfv_main

REPO = Path(__file__).resolve().parents[3]


# ---------------------------------------------------------------------- helpers
def random_frames(rng, frames=6, durations=None, closed=True):
    """Rows of a DeepMimic motion file (Y up): duration, root pos, root quat, joints.

    `closed`: the last frame repeats the first one moved horizontally, as a looped clip does.
    """
    rows = []
    for i in range(frames):
        row = [float(durations[i]) if durations is not None else float(rng.uniform(0.02, 0.05))]
        row += [0.3 * i, 0.85 + 0.01 * rng.normal(), 0.1 * i]
        row += list(rng.normal(size=4))  # unnormalised on purpose: the loader normalises
        for spherical in JOINT_IS_SPHERICAL:
            row += list(rng.normal(size=4)) if spherical else [float(rng.uniform(-2, 0))]
        rows.append(row)
    if closed:
        rows[-1][4:] = rows[0][4:]
        rows[-1][2] = rows[0][2]
    return rows


def write_deepmimic(path, frames, loop="wrap", **extra):
    path.write_text(json.dumps({"Loop": loop, "Frames": frames, **extra}))
    return path


def same_rotation(a, b):
    sign = np.where(np.sum(a * b, axis=-1, keepdims=True) < 0, -1.0, 1.0)
    return np.abs(a - sign * b).max()


@pytest.fixture
def clip(tmp_path):
    rng = np.random.default_rng(0)
    return load_motion(write_deepmimic(tmp_path / "clip.txt", random_frames(rng, 8)))


@pytest.fixture(scope="module")
def pybullet_motions():
    pybullet_data = pytest.importorskip("pybullet_data", reason="pybullet_data (the DeepMimic clips) is not installed")
    return Path(pybullet_data.getDataPath()) / "data" / "motions"


# ------------------------------------------------------------------ DeepMimic clips
@pytest.mark.parametrize("clip_name", DEEPMIMIC_CLIPS)
def test_deepmimic_clip_loads(pybullet_motions, clip_name):
    motion = load_motion(f"deepmimic:{clip_name}")
    raw = json.loads((pybullet_motions / f"humanoid3d_{clip_name}.txt").read_text())
    frames = np.array(raw["Frames"])
    assert motion.name == f"deepmimic:{clip_name}"
    assert motion.num_frames == len(frames) and motion.joint_rot.shape == (len(frames), NUM_JOINTS, 4)
    assert motion.loop == (raw["Loop"] == "wrap")
    np.testing.assert_allclose(motion.duration, frames[:-1, 0].sum(), rtol=1e-12)
    assert motion.frame_times[0] == 0.0 and (np.diff(motion.frame_times) > 0).all()
    np.testing.assert_allclose(np.linalg.norm(motion.root_rot, axis=-1), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(motion.joint_rot, axis=-1), 1.0, atol=1e-12)
    np.testing.assert_array_equal(motion.root_pos[0, :2], [0.0, 0.0])
    np.testing.assert_allclose(motion.root_pos[:, 2], frames[:, 2], atol=1e-12)  # Y-up height is Z-up z
    for array in (motion.root_pos, motion._root_lin_vel, motion._root_ang_vel, motion._joint_ang_vel):
        assert np.isfinite(array).all()


def test_deepmimic_axes_are_converted_as_rotations(tmp_path):
    """Rotating a Y-up vector and converting equals converting both, then rotating."""
    rng = np.random.default_rng(1)
    rows = random_frames(rng, 3)
    motion = load_motion(write_deepmimic(tmp_path / "axes.txt", rows))
    raw_root = np.array([r[4:8] for r in rows])
    raw_root /= np.linalg.norm(raw_root, axis=-1, keepdims=True)
    v = rng.normal(size=3)
    for i in range(3):
        rotated_yup = qn.quat_rotate(raw_root[i], v)
        np.testing.assert_allclose(qn.quat_rotate(motion.root_rot[i], yup_to_zup(v)), yup_to_zup(rotated_yup), atol=1e-12)
    raw_pos = np.array([r[1:4] for r in rows])
    np.testing.assert_allclose(motion.root_pos, [yup_to_zup(p - raw_pos[0] * [1, 0, 1]) for p in raw_pos], atol=1e-12)


# ----------------------------------------------------------------------------- npz
def test_npz_round_trip(tmp_path, clip):
    clip.extras["keypoints"] = np.arange(clip.num_frames * 6, dtype=np.float32).reshape(clip.num_frames, 2, 3)
    path = save_motion(clip, tmp_path / "sub" / "clip.npz")
    back = load_motion(path)
    assert (back.name, back.loop, back.num_frames) == (clip.name, clip.loop, clip.num_frames)
    for key in ("frame_times", "root_pos"):
        np.testing.assert_array_equal(getattr(back, key), getattr(clip, key))
    for key in ("root_rot", "joint_rot"):  # renormalised on load: equal to the last bit or two
        np.testing.assert_allclose(getattr(back, key), getattr(clip, key), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(back.extras["keypoints"], clip.extras["keypoints"])
    assert [p.name for p in path.parent.iterdir()] == ["clip.npz"], "no temp file left behind"


# ------------------------------------------------------------------------ sampling
def test_sample_at_frame_times_returns_the_frames(clip):
    pose = clip.sample(clip.frame_times)
    np.testing.assert_allclose(pose.root_pos, clip.root_pos, atol=1e-12)
    assert same_rotation(pose.root_rot, clip.root_rot) < 1e-12
    assert same_rotation(pose.joint_rot, clip.joint_rot) < 1e-12


def test_sample_between_frames_slerps(clip):
    i, w = 3, 0.3
    t = (1 - w) * clip.frame_times[i] + w * clip.frame_times[i + 1]
    pose = clip.sample(t)
    np.testing.assert_allclose(pose.root_pos, (1 - w) * clip.root_pos[i] + w * clip.root_pos[i + 1], atol=1e-12)
    assert pose.joint_rot.shape == (NUM_JOINTS, 4)
    pairs = ((clip.root_rot[i], clip.root_rot[i + 1], pose.root_rot), (clip.joint_rot[i, 2], clip.joint_rot[i + 1, 2], pose.joint_rot[2]))
    for a, b, got in pairs:
        # On the great circle: angle(a, got) = w * angle(a, b) and angle(got, b) = (1 - w) * angle(a, b).
        total = qn.quat_angle(qn.quat_mul(qn.quat_conj(a), b))
        np.testing.assert_allclose(qn.quat_angle(qn.quat_mul(qn.quat_conj(a), got)), w * total, atol=1e-9)
        np.testing.assert_allclose(qn.quat_angle(qn.quat_mul(qn.quat_conj(got), b)), (1 - w) * total, atol=1e-9)


def uniform_motion(rng, frames=7, loop=False):
    """A clip moving at constant velocities: the root translates and every rotation turns about a fixed axis."""
    times = np.concatenate(([0.0], np.cumsum(rng.uniform(0.02, 0.06, frames - 1))))
    def turning(shape):
        q0 = rng.normal(size=shape + (4,))
        q0 /= np.linalg.norm(q0, axis=-1, keepdims=True)
        omega = rng.normal(size=shape + (3,))  # rad/s in the child frame
        return np.stack([qn.quat_mul(q0, qn.quat_from_axis_angle(omega * t)) for t in times])
    joint_rot = turning((NUM_JOINTS,))
    # Revolute joints turn about their hinge axis (x in the skeleton): zero the other components.
    hinge = ~np.asarray(JOINT_IS_SPHERICAL)
    angle = rng.uniform(-2, 0, hinge.sum()) + rng.normal(size=hinge.sum()) * times[:, None]
    joint_rot[:, hinge] = qn.quat_from_axis_angle(angle[..., None] * np.array([1.0, 0.0, 0.0]))
    root_pos = np.array([0.0, 0.0, 0.9]) + np.outer(times, [0.4, -0.2, 0.1])
    return ReferenceMotion("uniform", times, root_pos, turning(()), joint_rot, loop=loop)


def test_velocities_integrate_to_the_next_frame_in_mujoco():
    """For a motion at constant velocities, the frame velocities, in MuJoCo's qvel conventions, carry frame i to i+1."""
    clip = uniform_motion(np.random.default_rng(0))
    humanoid = Humanoid()
    layout = StateLayout(humanoid)
    qpos, qvel, nxt, unused = np.zeros(humanoid.nq), np.zeros(humanoid.nv), np.zeros(humanoid.nq), np.zeros(humanoid.nv)
    for i in range(clip.num_frames - 1):
        dt = clip.frame_times[i + 1] - clip.frame_times[i]
        layout.pose_to_qpos_qvel(clip.sample(clip.frame_times[i]), qpos, qvel)
        layout.pose_to_qpos_qvel(clip.sample(clip.frame_times[i + 1]), nxt, unused)
        integrated = qpos.copy()
        mujoco.mj_integratePos(humanoid.model, integrated, qvel, dt)
        np.testing.assert_allclose(integrated[:3], nxt[:3], atol=1e-9)
        assert same_rotation(integrated[layout.ball_qpos], nxt[layout.ball_qpos]) < 1e-9
        assert same_rotation(integrated[3:7], nxt[3:7]) < 1e-9
        np.testing.assert_allclose(integrated[layout.hinge_qpos], nxt[layout.hinge_qpos], atol=1e-9)


def test_frame_velocities_are_central_differences():
    """A root moving on a parabola, unevenly sampled: a frame's velocity is the derivative there (not the next interval's)."""
    rng = np.random.default_rng(1)
    clip = uniform_motion(rng, frames=9)
    accel = np.array([1.5, -0.5, -3.0])
    clip = ReferenceMotion("parabola", clip.frame_times, clip.root_pos + 0.5 * np.outer(clip.frame_times**2, accel),
                           clip.root_rot, clip.joint_rot)
    inner = clip.frame_times[1:-1]
    expected = np.array([0.4, -0.2, 0.1]) + np.outer(inner, accel)
    np.testing.assert_allclose(clip.sample(inner).root_lin_vel, expected, atol=1e-9)


def test_looped_clip_velocity_is_continuous_across_the_wrap():
    clip = uniform_motion(np.random.default_rng(2), loop=True)
    ends = clip.sample(np.array([0.0, clip.duration]))
    np.testing.assert_allclose(ends.root_lin_vel[0], ends.root_lin_vel[1], atol=1e-9)



def test_looped_clip_repeats_with_cyclic_root_offset(clip):
    assert clip.loop
    offset = clip.cycle_offset
    assert offset[2] == 0.0 and np.linalg.norm(offset[:2]) > 0.1  # the clip walks forward
    np.testing.assert_allclose(offset[:2], clip.root_pos[-1, :2] - clip.root_pos[0, :2])
    t = np.array([0.0, 0.013, 0.1, clip.duration * 0.77])
    for cycles in (1, 3):
        later, now = clip.sample(t + cycles * clip.duration), clip.sample(t)
        np.testing.assert_allclose(later.root_pos, now.root_pos + cycles * offset, atol=1e-9)
        assert same_rotation(later.joint_rot, now.joint_rot) < 1e-9
        np.testing.assert_allclose(later.root_lin_vel, now.root_lin_vel, atol=1e-9)
    np.testing.assert_allclose(clip.phase(t + clip.duration), clip.phase(t), atol=1e-12)


def test_non_looped_clip_holds_its_last_frame(tmp_path):
    rng = np.random.default_rng(2)
    motion = load_motion(write_deepmimic(tmp_path / "once.txt", random_frames(rng, 5, closed=False), loop="none"))
    assert not motion.loop and not motion.cycle_offset.any()
    late = motion.sample(motion.duration + 3.0)
    np.testing.assert_allclose(late.root_pos, motion.root_pos[-1], atol=1e-12)
    assert same_rotation(late.joint_rot, motion.joint_rot[-1]) < 1e-12
    assert motion.phase(motion.duration + 3.0) == 1.0


# ---------------------------------------------------------------------- bad input
def deepmimic_case(name):
    rng = np.random.default_rng(3)
    good = random_frames(rng, 4)

    def with_value(frame, col, value):
        rows = [list(r) for r in good]
        rows[frame][col] = value
        return rows

    cases = {
        "not_json": b"\x00\x01 this is not a motion",
        "json_list": json.dumps([1, 2, 3]),
        "no_frames": json.dumps({"Loop": "wrap"}),
        "frames_not_rows": json.dumps({"Frames": [1, 2, 3]}),
        "short_row": json.dumps({"Frames": [good[0], good[1][:-1]]}),
        "long_rows": json.dumps({"Frames": [r + [0.0] for r in good]}),
        "text_value": json.dumps({"Frames": with_value(1, 5, "abc")}),
        "nan": json.dumps({"Frames": with_value(2, 10, float("nan"))}),
        "inf": json.dumps({"Frames": with_value(0, 2, float("inf"))}),
        "one_frame": json.dumps({"Frames": good[:1]}),
        "no_frame": json.dumps({"Frames": []}),
        "zero_duration": json.dumps({"Frames": with_value(1, 0, 0.0)}),
        "negative_duration": json.dumps({"Frames": with_value(0, 0, -0.1)}),
        "zero_root_quat": json.dumps({"Frames": [good[0], good[1][:4] + [0.0] * 4 + good[1][8:]] + good[2:]}),
        "zero_joint_quat": json.dumps({"Frames": [good[0], good[1][:8] + [0.0] * 4 + good[1][12:]] + good[2:]}),
        "bool_value": json.dumps({"Frames": with_value(1, 9, True)}),
        "string_number": json.dumps({"Frames": with_value(1, 9, "0.5")}),
        "huge_int": json.dumps({"Frames": with_value(1, 9, 10**400)}),
        # Finite numbers whose consequences are not: times or positions overflow, or a
        # positive duration vanishes next to a larger time.
        "durations_overflow": json.dumps({"Frames": [[1.7e308] + good[0][1:], [1.7e308] + good[1][1:]] + good[2:]}),
        "duration_vanishes": json.dumps({"Frames": [[1.0] + good[0][1:], [1e-17] + good[1][1:]] + good[2:]}),
        "positions_overflow": json.dumps({"Frames": [good[0][:1] + [1.7e308] + good[0][2:], good[1][:1] + [-1.7e308] + good[1][2:]] + good[2:]}),
        "denormal_duration": json.dumps({"Frames": with_value(0, 0, 5e-324)}),
    }
    return cases[name]


DEEPMIMIC_FAULTS = ["not_json", "json_list", "no_frames", "frames_not_rows", "short_row", "long_rows", "text_value", "nan",
                    "inf", "one_frame", "no_frame", "zero_duration", "negative_duration", "zero_root_quat", "zero_joint_quat",
                    "bool_value", "string_number", "huge_int", "durations_overflow", "duration_vanishes", "positions_overflow",
                    "denormal_duration"]


@pytest.mark.parametrize("fault", DEEPMIMIC_FAULTS)
def test_bad_deepmimic_file_is_a_motion_format_error(tmp_path, fault):
    content = deepmimic_case(fault)
    path = tmp_path / f"{fault}.txt"
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    with pytest.raises(MotionFormatError) as err:
        load_motion(path)
    message = str(err.value)
    assert message.startswith(str(path)) and "\n" not in message


def test_huge_quaternion_components_still_normalise(tmp_path):
    rows = random_frames(np.random.default_rng(5), 4)
    rows[1][4:8] = [1e300, 1e300, -1e300, 0.0]
    rows[2][8:12] = [1e-5, 0.0, 1e-5, 0.0]  # tiny but not zero
    motion = load_motion(write_deepmimic(tmp_path / "scaled.txt", rows))
    expected = qn.quat_normalize(np.array([1.0, 1.0, 0.0, -1.0]))  # Y-up (w, x, y, z) -> (w, x, -z, y)
    np.testing.assert_allclose(motion.root_rot[1], expected, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(motion.joint_rot, axis=-1), 1.0, atol=1e-12)


def npz_case(tmp_path, fault, clip):
    arrays = {
        "format": np.array("sfv-motion-1"), "name": np.array("x"), "loop": np.array(True),
        "frame_times": clip.frame_times, "root_pos": clip.root_pos, "root_rot": clip.root_rot, "joint_rot": clip.joint_rot,
    }
    T = clip.num_frames
    if fault.startswith("missing_"):
        del arrays[fault[len("missing_"):]]
    elif fault == "wrong_format":
        arrays["format"] = np.array("something-else")
    elif fault == "joint_rot_shape":
        arrays["joint_rot"] = np.ones((T, NUM_JOINTS - 1, 4))
    elif fault == "root_pos_shape":
        arrays["root_pos"] = np.ones((T, 2))
    elif fault == "frame_count_mismatch":
        arrays["root_pos"] = clip.root_pos[:-1]
    elif fault == "nan_root_pos":
        arrays["root_pos"] = np.where(np.arange(T)[:, None] == 2, np.nan, clip.root_pos)
    elif fault == "times_not_increasing":
        arrays["frame_times"] = clip.frame_times[::-1].copy()
    elif fault == "one_frame":
        arrays.update(frame_times=clip.frame_times[:1], root_pos=clip.root_pos[:1], root_rot=clip.root_rot[:1], joint_rot=clip.joint_rot[:1])
    elif fault == "zero_quat":
        arrays["joint_rot"] = clip.joint_rot.copy()
        arrays["joint_rot"][1, 4] = 0.0
    elif fault == "text_array":
        arrays["root_pos"] = np.full((T, 3), "a")
    elif fault == "joint_names":
        arrays["joint_names"] = np.array([f"j{i}" for i in range(NUM_JOINTS)])
    path = tmp_path / f"{fault}.npz"
    np.savez(path, **arrays)
    if fault == "truncated":
        path.write_bytes(path.read_bytes()[:200])
    return path


NPZ_FAULTS = ["missing_format", "missing_frame_times", "missing_root_pos", "missing_root_rot", "missing_joint_rot", "wrong_format",
              "joint_rot_shape", "root_pos_shape", "frame_count_mismatch", "nan_root_pos", "times_not_increasing", "one_frame",
              "zero_quat", "text_array", "joint_names", "truncated"]


@pytest.mark.parametrize("fault", NPZ_FAULTS)
def test_bad_npz_is_a_motion_format_error(tmp_path, clip, fault):
    path = npz_case(tmp_path, fault, clip)
    with pytest.raises(MotionFormatError) as err:
        load_motion(path)
    message = str(err.value)
    assert message.startswith(str(path)) and "\n" not in message


def test_missing_file_and_unknown_clip(tmp_path):
    with pytest.raises(MotionFormatError, match="nowhere.npz"):
        load_motion(tmp_path / "nowhere.npz")
    with pytest.raises(MotionFormatError, match="deepmimic:moonwalk"):
        load_motion("deepmimic:moonwalk")


# ---------------------------------------------------------------------------- CLI
def test_cli_motion_check_on_bad_file_exits_2_with_one_line(tmp_path):
    bad = tmp_path / "bad_motion.txt"
    bad.write_text(json.dumps({"Loop": "wrap", "Frames": [[0.1] * (DEEPMIMIC_COLUMNS - 1)] * 3}))
    result = subprocess.run([sys.executable, "-m", "services.cli", "motion", "check", str(bad)],
                            cwd=REPO, capture_output=True, text=True, timeout=120)
    assert result.returncode == 2
    assert result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("sfv: ") and str(bad) in lines[0] and "columns" in lines[0]


def test_cli_motion_check_and_convert(tmp_path, capsys):
    src = write_deepmimic(tmp_path / "good.txt", random_frames(np.random.default_rng(4), 10))
    out = tmp_path / "good.npz"
    assert sfv_main(["motion", "convert", str(src), "--out", str(out)]) == 0
    capsys.readouterr()
    converted, original = load_motion(out), load_motion(src)
    np.testing.assert_allclose(converted.joint_rot, original.joint_rot, rtol=0, atol=1e-15)
    assert sfv_main(["motion", "check", str(out), "--physics-hz", "600"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["frames"] == 10 and report["loop"] is True and report["joints"] == NUM_JOINTS
    assert report["duration"] == pytest.approx(original.duration, abs=1e-6)
    assert report["playback_reward"] >= 0.99
    # The largest joint angle between the last and the first frame (this writer closes its loops).
    dots = np.abs(np.sum(original.joint_rot[-1] * original.joint_rot[0], axis=-1))
    assert report["loop_wrap_mismatch_rad"] == pytest.approx(2 * np.arccos(np.clip(dots, 0, 1)).max(), abs=1e-3)


def test_cli_convert_of_bad_input_writes_nothing(tmp_path, capsys):
    bad = tmp_path / "bad.txt"
    bad.write_text(json.dumps({"Frames": []}))
    assert sfv_main(["motion", "convert", str(bad), "--out", str(tmp_path / "out.npz")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"sfv: {bad}") and err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.txt"]


def test_cli_rejects_physics_rate_that_is_not_a_multiple_of_control_rate(tmp_path, capsys, clip):
    path = save_motion(clip, tmp_path / "c.npz")
    assert sfv_main(["motion", "check", str(path), "--physics-hz", "100"]) == 2
    assert capsys.readouterr().err.startswith("sfv: --physics-hz 100")


def test_reference_motion_api_is_consistent(clip):
    assert isinstance(clip, ReferenceMotion)
    summary = clip.summary()
    assert summary["frames"] == clip.num_frames and summary["fps"] == pytest.approx((clip.num_frames - 1) / clip.duration, rel=1e-5)
