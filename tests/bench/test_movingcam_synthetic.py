"""bench/scripts/movingcam_synthetic.py: the synthetic motion it writes and its path figures."""
import numpy as np
import pytest

from tests.bench_scripts import load_bench_script

bench = load_bench_script("movingcam_synthetic")


def _paths(sim_xy, true_xy, sim_yaw, true_yaw):
    n = len(true_xy)
    return {"times": np.arange(1, n + 1) / 30.0, "sim_xy": sim_xy, "true_xy": true_xy, "sim_yaw": sim_yaw,
            "true_yaw": true_yaw, "start_xy": np.zeros(2), "contact_agreement": np.ones((n, 2), dtype=bool)}


def test_path_figures_measure_a_turned_and_shortened_path():
    t = np.arange(1, 31)[:, None] / 30.0
    true = np.hstack((t, np.zeros_like(t)))  # 1 m along +x
    turn = np.radians(30.0)
    sim = 0.5 * t * np.array([np.cos(turn), np.sin(turn)])  # half as far, 30 degrees off
    same = bench.path_figures(_paths(true, true, np.zeros(30), np.zeros(30)))
    assert same["path_error_per_m"] == 0.0 and same["heading_error_deg"] == 0.0 and same["distance_ratio"] == pytest.approx(1.0)
    off = bench.path_figures(_paths(sim, true, np.full(30, turn), np.zeros(30)))
    assert off["true_path_m"] == pytest.approx(1.0) and off["distance_ratio"] == pytest.approx(0.5)
    assert off["travel_direction_error_deg"] == pytest.approx(30.0) and off["heading_error_deg"] == pytest.approx(30.0)
    end_gap = np.linalg.norm(sim[-1] - true[-1])
    assert off["endpoint_error_per_m"] == pytest.approx(end_gap)


def test_synthetic_motion_is_root_free_with_the_clean_clips_cues(tmp_path):
    pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")
    from actors.envs.modes.movingcam.clip_cues import clip_cues
    from actors.motion.formats.io import load_motion, root_is_free

    clean = load_motion("deepmimic:walk")
    motion = load_motion(str(bench.prepare("deepmimic:walk", 0.05, 0, tmp_path)))
    assert root_is_free(motion) and np.ptp(motion.root_pos[:, :2], axis=0).max() == 0.0
    cues = clip_cues(clean)
    np.testing.assert_array_equal(motion.extras["contacts"], cues["contacts"])
    np.testing.assert_allclose(motion.extras["orientation_hint"], cues["orientation_hint"])
    angle = 2 * np.arccos(np.clip(np.abs(np.sum(motion.joint_rot * clean.joint_rot, axis=-1)), 0, 1))
    assert 0.02 < angle.mean() < 0.1  # the 0.05 rad noise, on every joint
