"""`sfv pipeline` on the real shared video: pose (Ray tasks) -> reconstruction (Ray task) -> training."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from actors.motion.formats.io import load_motion
from services.training.run_dir import read_metrics

pytestmark = pytest.mark.integration


def test_pipeline_video_to_controller(tmp_path, shared_dir):
    video = shared_dir / "data" / "video" / "pose2sim_balancing" / "cam01.mp4"
    models = shared_dir / "models" / "blazepose"
    if not video.exists() or not (models / "pose_landmark_full.tflite").exists():
        pytest.skip("shared video or BlazePose models absent")
    out = tmp_path / "pipe"
    cmd = [sys.executable, "-m", "services.cli", "pipeline", str(video), "--out", str(out), "--pose-models", str(models),
           "--iterations", "40", "--workers", "2", "--envs-per-worker", "2", "--init", "rsi", "--samples", "128",
           "--batch-size", "128", "--helped-max-samples", "128", "--body-alone-max-samples", "128",
           "--quiet"]  # one training per stage: no train-on loop at 128 samples (the default caps follow the clip: 1.3 M here)
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    summary = json.loads(done.stdout.strip().splitlines()[-1])
    motion = load_motion(summary["motion"])
    assert motion.num_frames == 100 and abs(motion.fps - 60.0) < 0.5
    assert "keypoints3d" in motion.extras
    rows = read_metrics(out / "train")
    assert rows and rows[-1]["samples"] == 128
    # Then the controller against the video: the finishing step's files, one result line each.
    files = summary["first_frame"]["files"]
    assert [name for name in ("motion", "bvh", "video", "overlay_strip", "report") if (out / Path(files[name]).name).is_file()] == \
        ["motion", "bvh", "video", "overlay_strip", "report"]
    report = json.loads((out / "report.json").read_text())
    assert report["frames"] == 51  # 100 frames at 60 fps: 1.65 s, 50 control steps
    # The reference reprojected at the control steps' video frames errs as the reconstruction says it does.
    assert abs(report["reprojection_error_px"]["reference"]["mean"] - float(motion.extras["reprojection_error_px"].mean())) < 3.0
    said = done.stdout.splitlines()
    assert all(any(line.endswith(files[name]) or f"{files[name]} (" in line for line in said) for name in files)


def test_pipeline_rejects_a_file_that_is_not_a_video(tmp_path):
    bad = tmp_path / "clip.mp4"
    bad.write_text("not a video")
    done = subprocess.run([sys.executable, "-m", "services.cli", "pipeline", str(bad), "--out", str(tmp_path / "o")],
                          capture_output=True, text=True, timeout=300)
    last = done.stderr.strip().splitlines()[-1]  # FFmpeg may log its own line first
    assert done.returncode == 2 and last.startswith("sfv: ") and "clip.mp4" in last
    assert not (tmp_path / "o" / "motion.npz").exists()
