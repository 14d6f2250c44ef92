"""bench/scripts/physics_vs_kinematics.py: the three motions against the markers, on a synthetic run directory."""
from __future__ import annotations

import json

import numpy as np
import pytest

from actors.motion.formats.io import save_motion
from actors.motion.reference_motion import ReferenceMotion
from services.reconstruction import JOINT_KEYPOINTS
from tests.bench_scripts import load_bench_script

FRAMES, FPS = 61, 60.0


@pytest.fixture(scope="module")
def bench():
    return load_bench_script("physics_vs_kinematics")


def _motion(frames: int, fps: float, **extras) -> ReferenceMotion:
    joint_rot = np.zeros((frames, 12, 4))
    joint_rot[..., 0] = 1.0
    root_rot = np.tile([1.0, 0.0, 0.0, 0.0], (frames, 1))
    root_pos = np.tile([0.0, 0.0, 0.885], (frames, 1))
    return ReferenceMotion("m", np.arange(frames) / fps, root_pos, root_rot, joint_rot, loop=False, extras=extras)


def test_a_reconstruction_equal_to_the_markers_scores_zero_and_a_bent_arm_does_not(tmp_path, bench):
    rng = np.random.default_rng(0)
    t = np.arange(FRAMES)[:, None, None] / FPS
    truth = rng.uniform(-0.3, 0.3, (1, 12, 3)) + [0.0, 0.0, 1.0] + 0.05 * np.sin(2 * np.pi * t + rng.uniform(0, 6, (1, 12, 3)))
    feet = np.zeros((FRAMES, 6, 3))
    feet[:, 3:, 0] = 0.2 * t[:, 0]  # the left foot's markers slide 0.2 m/s on the floor, the right ones stand
    names = list(JOINT_KEYPOINTS) + [n for foot in bench.FOOT_MARKERS for n in foot]
    markers = np.concatenate((truth, feet), axis=1)
    run = tmp_path / "cam01"
    run.mkdir()
    save_motion(_motion(FRAMES, FPS, raw_keypoints3d=truth + rng.normal(0, 0.02, truth.shape), keypoints3d=truth),
                run / "motion.npz")
    bent = truth[::2].copy()
    bent[:, JOINT_KEYPOINTS.index("RWrist")] += [0.0, 0.0, 0.15]  # the simulated right hand 15 cm high
    save_motion(_motion(31, 30.0, keypoints3d=bent), run / "simulated.npz")
    report = {"control_hz": 30.0, "fell": False, "fell_at_s": None, "normalized_return": 0.9, "video_start_frame": 0,
              "foot_skating_m_s": {"simulated": 0.01, "reference": 0.2},
              "ground_penetration_m": {"simulated": {"mean": 0.0, "max": 0.001}, "reference": {"mean": 0.0, "max": 0.0}}}
    (run / "report.json").write_text(json.dumps(report))
    result = bench.measure(run, names, markers)
    kinematic, simulated, raw = result["kinematic"], result["simulated"], result["raw"]
    for key in ("pa_mpjpe_mm", "mpjpe_mm", "world_mpjpe_mm", "accel_error_mm"):
        assert kinematic[key] == pytest.approx(0.0, abs=0.05)
        assert simulated[key] >= 0.0 and raw[key] > 0.0
    assert simulated["mpjpe_mm"] > 5.0 and simulated["pa_mpjpe_mm"] > 5.0  # one joint of 12 is 150 mm off
    assert simulated["accel_error_mm"] < 1.0  # a constant offset hardly accelerates (only through the alignment)
    assert kinematic["foot_skating_m_s"] == 0.2 and simulated["ground_penetration_m"]["max"] == 0.001
    assert raw["foot_skating_m_s"] is None
    # Markers: the sliding left foot skates 0.2 m/s, the right one stands: their mean over contact pairs is 0.1.
    assert result["markers"]["foot_skating_m_s"] == pytest.approx(0.1, rel=1e-6)
    assert result["frames"] == 31
    assert "| cam01 | simulated |" in bench.markdown({"cam01": result})


def test_without_the_shared_clip_it_exits_2(tmp_path, bench, capsys):
    assert bench.main(["--runs", str(tmp_path), "--shared", str(tmp_path / "nowhere")]) == 2
    assert "needs ../shared" in capsys.readouterr().err
