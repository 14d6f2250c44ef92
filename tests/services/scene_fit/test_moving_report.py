"""The moving pipeline's defaults and outputs: a per-window budget chosen for a window, the
coverage line when the simulated motion stops short, and report.json (real windows trained in
process with tiny budgets, real MuJoCo)."""
from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest

from actors.motion.formats.io import load_motion
from services.scene_fit.coverage import coverage
from services.scene_fit.windows import split_windows

FRAME_TIMES = np.arange(100) / 30.0


def _simulated(clip_frames, windows_of, fell=None):
    return SimpleNamespace(clip_frames=np.asarray(clip_frames), window_of_frame=np.asarray(windows_of), fell_at_frame=fell)


def test_a_fall_is_one_line_naming_the_frame_the_window_and_the_frames_covered():
    windows = split_windows(100, [(30, 0), (60, 1)], max_objects=1)
    sim = _simulated(range(0, 46), [0] * 30 + [1] * 16, fell=45)
    cover = coverage(sim, windows, FRAME_TIMES)
    assert (cover.frames_covered, cover.fell_in_window, cover.fell_at_s) == (46, 1, 1.5)
    assert not cover.complete
    assert cover.line.startswith("fell at clip frame 45 (1.50 s) in window 1 (frames 30..99): ")
    assert "covers clip frames 0..45 of 100 (46 %)" in cover.line


def test_a_window_that_hands_over_early_is_named_with_the_frames_skipped():
    windows = split_windows(100, [(30, 0), (60, 1)], max_objects=1)
    sim = _simulated(list(range(0, 21)) + list(range(30, 100)), [0] * 21 + [1] * 70)
    cover = coverage(sim, windows, FRAME_TIMES)
    assert cover.frames_covered == 21 and cover.fell_at_frame is None
    assert "window 0 stopped at clip frame 20" in cover.line and "skips clip frames 21..29" in cover.line


def test_the_whole_clip_upright_is_complete():
    windows = split_windows(100, [], max_objects=1)
    cover = coverage(_simulated(range(100), [0] * 100), windows, FRAME_TIMES)
    assert cover.complete and cover.line.startswith("completed")
    short = coverage(_simulated(range(80), [0] * 80), windows, FRAME_TIMES)
    assert short.frames_covered == 80 and "stopped upright at clip frame 79 of 100" in short.line


def test_the_window_budget_is_the_moving_pipelines_own_default_and_a_flag_wins(tmp_path):
    pytest.importorskip("actors.envs.modes.movingcam.tracking")
    from services.cli import build_parser
    from services.commands._moving_pipeline import _base_config
    from services.scene_fit.budget import WINDOW_SAMPLES

    argv = ["pipeline", str(tmp_path / "v.mp4"), "--out", str(tmp_path / "o"), "--camera", "moving"]
    config = _base_config(build_parser(argv).parse_args(argv), None)
    assert config.samples == WINDOW_SAMPLES and config.env.movingcam.path_weight > 0  # the path cue on
    argv += ["--samples", "4096", "--env.movingcam.path-weight", "0"]
    config = _base_config(build_parser(argv).parse_args(argv), None)
    assert config.samples == 4096 and config.env.movingcam.path_weight == 0.0
    assert WINDOW_SAMPLES > 200_000  # sfv train's quick default fell at frame 39 of 312 (issue 48)


def _root_free_walk(tmp_path):
    from actors.motion.formats.io import save_motion

    motion = load_motion("deepmimic:walk")
    motion.loop = False
    motion.extras["root_free"] = np.array(True)
    motion.extras["orientation_hint"] = np.zeros(motion.num_frames)
    motion.extras["contacts"] = np.ones((motion.num_frames, 2), bool)
    return save_motion(motion, tmp_path / "motion.npz")


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    pytest.importorskip("actors.envs.modes.movingcam.tracking")
    from actors.envs.imitation_env import EnvConfig
    from services.scene_fit import scene_contract
    from services.scene_fit.report import write_moving_report
    from services.scene_fit.stage import run_scene_fit
    from services.training.config import TrainConfig

    out = tmp_path_factory.mktemp("moving_report")
    base = TrainConfig(motion="", out="", workers=1, envs_per_worker=2, init="rsi", samples=128, runner="in_process",
                       eval_every=0, plot_every=0, torch_threads=1)
    base.env = scene_contract.movingcam_env(EnvConfig(), None)
    base.ppo.batch_size, base.ppo.minibatch_size = 128, 64
    outcome = run_scene_fit(str(_root_free_walk(out)), None, out, base, rollouts=2, progress=False, fit_starts=1)
    report = write_moving_report(outcome, out, {"video": "v.mp4"})
    return out, outcome, report


def test_report_json_says_what_the_simulated_motion_covers(fitted):
    out, outcome, report = fitted
    written = json.loads((out / "report.json").read_text())
    assert written["coverage"] == report["coverage"] == outcome.summary["coverage"]["line"]
    simulated = load_motion(str(out / "simulated.npz"))
    last = int(np.asarray(simulated.extras["clip_frame"]).max())
    clip = load_motion(str(out / "motion.npz"))
    assert written["clip_frames"] == clip.num_frames and written["frames"] == simulated.num_frames
    if written["fell"]:  # 128 samples: a fall is the likely result, and then the file stops there
        assert written["fell_at_frame"] == last and written["frames_covered"] == last + 1 < clip.num_frames
        assert written["fell_at_s"] == pytest.approx(clip.frame_times[last], abs=1e-3)
        assert f"window {written['fell_in_window']}" in written["coverage"] and written["outcome"].startswith(("fell", "diverged"))
    else:
        assert written["frames_covered"] == last + 1 == clip.num_frames and written["coverage"].startswith("completed")
    assert written["windows"][0]["samples"] >= 128 and written["windows"][0]["end"] == clip.num_frames - 1
    errors = written["root_relative_joint_error_m"]
    assert len(errors["per_frame"]) == simulated.num_frames and 0 < errors["mean"] <= errors["max"] < 1.0


def test_report_json_is_written_whole_beside_the_outputs(fitted):
    out, outcome, report = fitted
    assert sorted(p.name for p in out.iterdir() if p.suffix in (".json", ".npz", ".bvh")) == \
        ["motion.npz", "report.json", "scene_fit.json", "simulated.bvh", "simulated.npz"]
    assert report["files"]["report"] == str(out / "report.json") and report["files"]["motion"].endswith("simulated.npz")
    assert set(report["foot_skating_m_s"]) == {"simulated", "reference"}


def test_the_pipeline_prints_a_result_line_per_window_then_the_coverage_and_the_outcome(fitted, tmp_path):
    from services.commands._moving_pipeline import _report

    out, outcome, _ = fitted
    lines: list[str] = []
    args = SimpleNamespace(out=tmp_path, video=tmp_path / "v.mp4")
    report = _report(outcome, args, out / "motion.npz", str(tmp_path / "simulated.mp4"), say=lines.append)
    assert lines[0].startswith("window 0: clip frames 0..") and "128 samples" in lines[0]
    assert lines[1] == report["coverage"] and lines[-1] == report["outcome"]
    assert json.loads((tmp_path / "report.json").read_text())["files"]["video"] == str(tmp_path / "simulated.mp4")
