"""bench/scripts/body_alone_stage.py: the helped rollout made the reference of a body-alone training."""
from __future__ import annotations

import numpy as np
import pytest

from learner.errors import SfvError
from tests.bench_scripts import load_bench_script


def write_run(folder, fell_at_s=float("nan")):
    """A 60 fps reconstruction of 10 frames and a 30 Hz helped rollout of 5 control steps."""
    frames, steps = 10, 5
    times = np.arange(frames) / 60.0
    np.savez(folder / "motion.npz", frame_times=times, fps=np.asarray(60.0), root_pos=np.zeros((frames, 3)),
             root_rot=np.tile([1.0, 0, 0, 0], (frames, 1)), joint_rot=np.tile([1.0, 0, 0, 0], (frames, 12, 1)),
             contacts=(np.arange(frames * 2).reshape(frames, 2) % 3 == 0), keypoints2d=np.arange(frames * 24.0).reshape(frames, 12, 2),
             camera_intrinsics=np.eye(3))
    rollout = np.arange(steps, dtype=float)[:, None] * np.array([0.1, 0.0, 0.0]) + np.array([0.0, 0.0, 0.9])
    np.savez(folder / "simulated.npz", frame_times=np.arange(steps) / 30.0, root_pos=rollout,
             root_rot=np.tile([0.0, 0, 0, 1.0], (steps, 1)), joint_rot=np.tile([0.0, 1.0, 0, 0], (steps, 12, 1)),
             fell_at_s=np.asarray(fell_at_s))
    return rollout


def test_the_rollout_s_poses_replace_the_reconstruction_s_at_the_control_rate(tmp_path):
    stage = load_bench_script("body_alone_stage")
    rollout = write_run(tmp_path)
    made = np.load(stage.helped_reference(tmp_path, tmp_path / "alone"))
    source = np.load(tmp_path / "motion.npz")
    assert np.allclose(made["root_pos"], rollout) and np.allclose(made["joint_rot"][..., 1], 1.0)
    assert float(made["fps"]) == pytest.approx(30.0)
    # The per-frame fields are the reconstruction's frames nearest each control step (0, 2, 4, 6, 8);
    # the camera is kept whole.
    assert np.array_equal(made["contacts"], source["contacts"][::2])
    assert np.array_equal(made["keypoints2d"], source["keypoints2d"][::2])
    assert np.array_equal(made["camera_intrinsics"], np.eye(3))


def test_a_rollout_that_fell_is_refused(tmp_path):
    stage = load_bench_script("body_alone_stage")
    write_run(tmp_path, fell_at_s=0.05)
    with pytest.raises(SfvError, match="fell at 0.05 s"):
        stage.helped_reference(tmp_path, tmp_path / "alone")
    assert not (tmp_path / "alone" / "motion.npz").exists()
