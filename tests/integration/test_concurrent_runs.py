"""Runs that share a machine: two Ray-runner trainings and a video pipeline started together,
each with its own private local Ray, all finish (a second local Ray used to lose its raylet to
the dashboard agent's fixed port)."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

pytestmark = [pytest.mark.integration, pytest.mark.slow]


def _train(out) -> list[str]:
    return [sys.executable, "-m", "services.cli", "train", "--runner", "ray", "--workers", "2", "--envs-per-worker", "2",
            "--init", "rsi", "--samples", "768", "--batch-size", "128", "--hidden", "32,16", "--eval-every", "0",
            "--out", str(out), "--quiet"]


def _pipeline(video, models, out) -> list[str]:
    return [sys.executable, "-m", "services.cli", "pipeline", str(video), "--out", str(out), "--pose-models", str(models),
            "--iterations", "20", "--workers", "2", "--envs-per-worker", "2", "--init", "rsi", "--samples", "128",
            "--batch-size", "128", "--helped-max-samples", "128", "--body-alone-max-samples", "128", "--quiet"]


def test_two_trainings_and_a_pipeline_at_once_all_finish(tmp_path, shared_dir):
    commands = {"train_a": _train(tmp_path / "a"), "train_b": _train(tmp_path / "b")}
    video = shared_dir / "data" / "video" / "pose2sim_balancing" / "cam01.mp4"
    models = shared_dir / "models" / "blazepose"
    if video.exists() and (models / "pose_landmark_full.tflite").exists():
        commands["pipeline"] = _pipeline(video, models, tmp_path / "pipe")
    running = {name: subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
               for name, cmd in commands.items()}
    outcomes = {name: proc.communicate(timeout=1500) + (proc.returncode,) for name, proc in running.items()}
    for name, (stdout, stderr, code) in outcomes.items():
        assert code == 0, f"{name}: {stderr[-1500:]}"
    for name in ("train_a", "train_b"):
        assert json.loads(outcomes[name][0].strip().splitlines()[-1])["samples"] == 768
    if "pipeline" in outcomes:
        assert (tmp_path / "pipe" / "report.json").is_file()
