"""`sfv bench --suite videos`: one row per video from its pipeline run; the person followed is
found among the Pose2Sim markers; bad input is one line."""
from __future__ import annotations

import json

import numpy as np
import pytest

from actors.motion.formats.io import save_motion
from actors.motion.reference_motion import ReferenceMotion
from services.bench.videos_suite import MINUTES_FILE, markdown
from services.bench.videos_truth import followed_truth
from services.cli import main
from tests.conftest import SHARED

TWO_PEOPLE = SHARED / "data" / "video" / "pose2sim_two_people"


def _motion(frames: int, extras: dict) -> ReferenceMotion:
    identity = np.tile([1.0, 0.0, 0.0, 0.0], (frames, 1))
    return ReferenceMotion("m", np.arange(frames) / 30.0, np.tile([0.0, 0.0, 0.9], (frames, 1)), identity,
                           np.tile(identity[:, None], (1, 12, 1)), loop=False, extras=extras)


def _finished_run(run, fell: bool, alone: bool = False) -> None:
    """What a finished `sfv pipeline` leaves: report.json, motion.npz, simulated.npz, the strip; `alone`:
    a helped controller that completes, falls without its help, and a body-alone stage that completes."""
    run.mkdir(parents=True)
    joints = np.zeros((10, 12, 3))
    save_motion(_motion(10, {"video_start_frame": np.array(4), "person_id": np.array(1), "keypoints3d": joints,
                             "keypoints2d": np.zeros((10, 12, 2))}), run / "motion.npz")
    save_motion(_motion(10, {"keypoints3d": joints}), run / "simulated.npz")
    import cv2

    cv2.imwrite(str(run / "overlay_strip.png"), np.full((480, 1632, 3), 90, np.uint8))
    (run / "pipeline_stdout.txt").write_text("subject: person 1 of 2 (seen throughout and moves most)\n")
    (run / MINUTES_FILE).write_text(json.dumps({"minutes": 12.5}))
    report = {"control_hz": 30.0, "fell": fell, "fell_at_s": 0.2 if fell else None, "normalized_return": 0.5,
              "outcome": "fell at 0.20 s: first cause found: drift" if fell else "completed: upright",
              "reference_check": "reference check: nothing to repair",
              "reprojection_error_px": {"simulated": {"mean": 40.0}, "reference": {"mean": 12.0}},
              "foot_skating_m_s": {"simulated": 0.5, "reference": 0.4},
              "ground_penetration_m": {"simulated": {"mean": 0.01, "max": 0.02}, "reference": {"mean": 0.0, "max": 0.0}},
              "root_relative_joint_error_m": {"mean": 0.1}, "world_aligned_joint_error_m": {"mean": 0.2},
              "residual_force_body_weight": {"mean": 0.114, "max": 0.192} if fell else None,
              **({"without_residual_force": {"fell": True, "fell_at_s": 0.1, "normalized_return": 0.2}} if fell or alone else {}),
              "body_alone": {"ran": False, "line": "the body-alone stage: not needed"}}
    if alone:
        (run / "alone").mkdir()
        cv2.imwrite(str(run / "alone" / "overlay_strip.png"), np.full((480, 1632, 3), 60, np.uint8))
        report["residual_force_body_weight"] = {"mean": 0.08, "max": 0.1}
        report["body_alone"] = {"ran": True, "line": "the body-alone stage: training", "fell": False, "fell_at_s": None,
                                "normalized_return": 0.861, "directory": str(run / "alone")}
    (run / "report.json").write_text(json.dumps(report))


def test_the_suite_measures_finished_runs_and_writes_one_row_per_video(tmp_path, capsys):
    videos = tmp_path / "clips"
    videos.mkdir()
    for name in ("a.mp4", "b.mp4"):
        (videos / name).write_bytes(b"")
    (videos / "notes.txt").write_text("not a video")
    (videos / "LICENSE").write_text("\nCC-BY 4.0, someone\n")
    runs, out = tmp_path / "runs", tmp_path / "videos.json"
    (videos / "c.mp4").write_bytes(b"")
    _finished_run(runs / "clips_a", fell=False)
    _finished_run(runs / "clips_b", fell=True)
    _finished_run(runs / "clips_c", fell=False, alone=True)
    assert main(["bench", "--suite", "videos", "--videos", str(videos), "--runs-dir", str(runs), "--out", str(out),
                 "--quiet"]) == 0
    document = json.loads(out.read_text())
    rows = document["rows"]
    assert [r["run"].split("/")[-1] for r in rows] == ["clips_a", "clips_b", "clips_c"] and document["completed"] == 2
    # Without help: a (trained with none) and c (its body-alone stage) complete; b's helped controller fell.
    assert [r["completed_without_help"] for r in rows] == [True, False, True] and document["completed_without_help"] == 2
    assert "| 0.08 / 0.10; alone: fell at 0.10 s | completed, NR 0.861 | 12.5 |" in markdown(rows)
    assert rows[2]["strip_body_alone"] == str(tmp_path / "videos_clips_c_body_alone.png")
    assert rows[0]["licence"] == "CC-BY 4.0, someone" and rows[0]["minutes"] == 12.5
    assert rows[0]["subject"] == {"person": 1, "frames": [4, 13], "line": "subject: person 1 of 2 (seen throughout and moves most)"}
    assert rows[1]["outcome"].startswith("fell at 0.20 s") and rows[0]["ground_truth"] is None
    import cv2

    assert cv2.imread(str(tmp_path / "videos_clips_b.png")).shape == (294, 1000, 3)  # 1632 x 480 scaled to 1000 wide
    assert sorted(p.name for p in tmp_path.iterdir() if p.is_file()) == [
        "videos.json", "videos_clips_a.png", "videos_clips_b.png", "videos_clips_c.png", "videos_clips_c_body_alone.png"]
    table = capsys.readouterr().out
    assert "| clips_a | 4-13 (person 1) | 12.0 / 40.0 | 0.40 / 0.50 | 2.0 | - | completed | 0.500 | none | - | 12.5 |" in table
    assert "| fell at 0.20 s | 0.500 | 0.11 / 0.19; alone: fell at 0.10 s | - | 12.5 |" in markdown(rows)
    assert rows[0]["without_residual_force"] is None
    assert rows[1]["residual_force_body_weight"] == {"mean": 0.114, "max": 0.192}


def test_the_table_grows_a_video_at_a_time_and_a_video_run_again_replaces_its_row(tmp_path):
    videos = tmp_path / "clips"
    videos.mkdir()
    for name in ("a.mp4", "b.mp4"):
        (videos / name).write_bytes(b"")
    runs, out = tmp_path / "runs", tmp_path / "videos.json"
    _finished_run(runs / "clips_a", fell=False)
    _finished_run(runs / "clips_b", fell=True)
    for name in ("b.mp4", "a.mp4"):
        assert main(["bench", "--suite", "videos", "--videos", str(videos / name), "--runs-dir", str(runs), "--out",
                     str(out), "--quiet"]) == 0
    document = json.loads(out.read_text())
    assert [r["run"].split("/")[-1] for r in document["rows"]] == ["clips_a", "clips_b"] and document["completed"] == 1
    (runs / "clips_b" / "report.json").write_text((runs / "clips_a" / "report.json").read_text())  # b now completes
    assert main(["bench", "--suite", "videos", "--videos", str(videos / "b.mp4"), "--runs-dir", str(runs), "--out",
                 str(out), "--quiet"]) == 0
    document = json.loads(out.read_text())
    assert len(document["rows"]) == 2 and document["completed"] == 2
    out.write_text(json.dumps({"suite": "env", "rows": []}))
    assert main(["bench", "--suite", "videos", "--videos", str(videos / "b.mp4"), "--runs-dir", str(runs), "--out",
                 str(out), "--quiet"]) == 2


def test_bad_input_is_one_line(tmp_path, capsys):
    assert main(["bench", "--suite", "videos", "--videos", str(tmp_path / "none.mp4"), "--out",
                 str(tmp_path / "v.json")]) == 2
    assert f"--videos {tmp_path / 'none.mp4'}: not a video file or a folder of videos" in capsys.readouterr().err
    assert main(["bench", "--suite", "videos,env", "--out", str(tmp_path / "v.json")]) == 2
    assert "the videos suite runs on its own" in capsys.readouterr().err
    assert main(["bench", "--suite", "videos", "--out", str(tmp_path / "v.txt")]) == 2
    assert "--suite videos needs --out FILE.json" in capsys.readouterr().err


@pytest.mark.shared
def test_the_person_followed_is_found_among_the_markers():
    if not (TWO_PEOPLE / "cam02.mp4").is_file():
        pytest.skip("../shared absent: needs the Pose2Sim two-people trial")
    from actors.motion.formats.trc import read_trc
    from services.bench.videos_truth import CALIBRATION, project
    from services.reconstruction import JOINT_KEYPOINTS
    import tomllib

    frames = np.arange(0, 100, 2)
    calibration = tomllib.loads((TWO_PEOPLE / CALIBRATION).read_text())["cam_02"]
    for person in ("P1", "P2"):
        trc = next(TWO_PEOPLE.glob(f"*_{person}_0-100.trc"))
        names, world = read_trc(trc)
        joints = world[frames][:, [names.index(n) for n in JOINT_KEYPOINTS]]
        seen = project(joints, calibration) + np.random.default_rng(0).normal(0, 8.0, (len(frames), 12, 2))
        path, truth = followed_truth(TWO_PEOPLE / "cam02.mp4", seen, frames)
        assert path == trc and np.array_equal(truth, joints, equal_nan=True)
    assert followed_truth(TWO_PEOPLE / "other.mp4", seen, frames) is None  # no camera of that name


def test_minutes_count_from_the_first_start_and_a_resumed_run_adds_to_its_minutes(tmp_path, monkeypatch):
    import subprocess
    import time

    from services.bench import videos_suite

    calls = []
    monkeypatch.setattr(videos_suite.subprocess, "run",
                        lambda command, **kw: calls.append(command) or subprocess.CompletedProcess(command, 0))
    resumed = tmp_path / "resumed"
    resumed.mkdir()
    (resumed / videos_suite.STARTED_FILE).write_text(json.dumps({"started": time.time() - 30 * 60}))
    assert videos_suite.run_pipeline(tmp_path / "v.mp4", resumed, lambda line: None) == pytest.approx(30.0, abs=0.2)
    refinished = tmp_path / "refinished"
    (refinished / "train").mkdir(parents=True)
    for name in ("motion.npz", "train/config.json"):
        (refinished / name).write_text("")
    (refinished / MINUTES_FILE).write_text(json.dumps({"minutes": 16.2}))  # measured before the body-alone stage
    assert videos_suite.run_pipeline(tmp_path / "v.mp4", refinished, lambda line: None) == pytest.approx(16.2, abs=0.1)
    assert "--resume" in calls[-1] and "--resume" not in calls[0]
    assert json.loads((refinished / MINUTES_FILE).read_text())["minutes"] == pytest.approx(16.2, abs=0.1)
