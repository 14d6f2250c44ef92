"""`sfv export RUN --motion X.npz --bvh X.bvh`: recorded rollouts as sfv motions and BVH."""
from __future__ import annotations

import json

import numpy as np
import pytest

from actors.character import quaternion as qn
from actors.motion.formats.bvh import load_bvh_motion
from actors.motion.formats.io import load_motion
from services.cli import main
from services.training.evaluation import evaluate_policy
from services.training.policy_source import load_policy_source
from tests.services.export.test_export_onnx import make_tiny_run

pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    path = tmp_path_factory.mktemp("export") / "walk_rsi"
    make_tiny_run(path, seed=2)
    return path


@pytest.fixture(scope="module")
def exported(run_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("rollout")
    assert main(["export", str(run_dir), "--motion", str(out / "roll.npz"), "--bvh", str(out / "roll.bvh"),
                 "--seconds", "0.8", "--episodes", "2", "--init", "rsi", "--seed", "5"]) == 0
    return out


def test_one_file_pair_per_episode_with_one_frame_per_control_step(run_dir, exported):
    names = sorted(p.name for p in exported.iterdir())
    assert names == ["roll_ep01.bvh", "roll_ep01.npz", "roll_ep02.bvh", "roll_ep02.npz"]
    source = load_policy_source(run_dir)
    env = source.make_env()
    for episode in (0, 1):
        motion = load_motion(str(exported / f"roll_ep{episode + 1:02d}.npz"))
        steps = evaluate_policy(source.policy, env, 1, seed=5 + episode, init="rsi")["episode_length"]
        assert motion.num_frames == min(int(steps), 24) + 1
        np.testing.assert_allclose(np.diff(motion.frame_times), 1 / 30.0)


def test_first_frame_is_the_reference_the_episode_started_on(run_dir, exported):
    source = load_policy_source(run_dir)
    env = source.make_env()
    env.reset(seed=5, options={"init": "rsi"})  # same seed and init as the export's first episode
    start = env.track.qpos[env.row]
    motion = load_motion(str(exported / "roll_ep01.npz"))
    np.testing.assert_allclose(motion.root_pos[0], start[0:3], atol=1e-9)
    np.testing.assert_allclose(np.abs(qn.quat_mul(qn.quat_conj(motion.root_rot[0]), start[3:7])[0]), 1.0, atol=1e-9)
    assert not np.allclose(motion.root_pos[-1], motion.root_pos[0])  # the character moved


@pytest.mark.parametrize("phase", [0.0, 0.55])
def test_a_start_phase_starts_every_episode_on_that_reference_frame(run_dir, tmp_path, phase):
    assert main(["export", str(run_dir), "--motion", str(tmp_path / "at.npz"), "--seconds", "0.2", "--episodes", "2",
                 "--phase", str(phase), "--seed", "3"]) == 0
    env = load_policy_source(run_dir).make_env()
    start = env.track.qpos[env.track.start_index(phase)]
    for episode in ("01", "02"):  # both seeds: the phase, not the seed, decides the start
        motion = load_motion(str(tmp_path / f"at_ep{episode}.npz"))
        np.testing.assert_allclose(motion.root_pos[0], start[0:3], atol=1e-9)
    assert (phase == 0.0) == np.allclose(start[0:3], env.track.qpos[0, 0:3])


def test_bvh_and_npz_hold_the_same_motion(exported):
    for episode in ("01", "02"):
        npz = load_motion(str(exported / f"roll_ep{episode}.npz"))
        bvh = load_bvh_motion(exported / f"roll_ep{episode}.bvh")
        assert bvh.num_frames == npz.num_frames
        angle = qn.quat_angle(qn.quat_mul(qn.quat_conj(npz.joint_rot), bvh.joint_rot))
        assert angle.max() < 1e-4
        np.testing.assert_allclose(bvh.root_pos, npz.root_pos, atol=1e-6)


def test_a_single_episode_writes_the_names_given(run_dir, tmp_path, capsys):
    assert main(["export", str(run_dir), "--bvh", str(tmp_path / "walk.bvh"), "--seconds", "0.2", "--units", "m"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert [p.name for p in tmp_path.iterdir()] == ["walk.bvh"]
    assert report["rollouts"][0]["bvh"] == str(tmp_path / "walk.bvh") and report["rollouts"][0]["frames"] == 7
    assert "OFFSET 0.000000 0.236151 0.000000" in (tmp_path / "walk.bvh").read_text()  # metres


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--motion", "{tmp}/x.bvh"], "--motion must name a .npz file"),
        (["--bvh", "{tmp}/x.npz"], "--bvh must name a .bvh file"),
        (["--bvh", "{tmp}/x.bvh", "--episodes", "0"], "--episodes must be positive"),
        (["--bvh", "{tmp}/x.bvh", "--seconds", "-1"], "--seconds must be positive"),
        (["--bvh", "{tmp}/x.bvh", "--phase", "-0.1"], "--phase must be in [0, 1]"),
    ],
)
def test_bad_arguments_are_one_line_errors(run_dir, tmp_path, capsys, argv, message):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert main(["export", str(run_dir), *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("sfv: ") and message in err and "\n" not in err
    assert list(tmp_path.iterdir()) == []
