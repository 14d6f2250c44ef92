"""`sfv complete` end to end: a real video frame, the real BlazePose models, two runs trained
here with the real Trainer, real MuJoCo simulation and off-screen rendering, a real MP4."""
from __future__ import annotations

import json

import cv2
import imageio.v2 as imageio
import numpy as np
import pytest

from services.cli import main
from services.training.config import TrainConfig
from services.training.driver import Trainer

pytestmark = pytest.mark.integration
pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")
SECONDS = 0.3  # short enough that even a barely trained policy has not fallen yet (toppling takes > 0.5 s)
HEIGHT, SIM_WIDTH = 240, 320


@pytest.fixture(scope="module")
def pose_models(shared_dir):
    models = shared_dir / "models" / "blazepose"
    if not (models / "pose_detection.tflite").is_file() or not (models / "pose_landmark_full.tflite").is_file():
        pytest.skip("BlazePose models absent from ../shared/models/blazepose")
    return models


@pytest.fixture(scope="module")
def still_image(shared_dir, tmp_path_factory):
    video = shared_dir / "data" / "video" / "pose2sim_balancing" / "cam01.mp4"
    if not video.is_file():
        pytest.skip(f"{video} absent")
    capture = cv2.VideoCapture(str(video))
    capture.set(cv2.CAP_PROP_POS_FRAMES, 30)
    ok, frame = capture.read()
    capture.release()
    assert ok, f"{video}: cannot decode frame 30"
    path = tmp_path_factory.mktemp("still") / "balancing_30.png"
    cv2.imwrite(str(path), frame)
    return path


def tiny_run(out, motion: str) -> None:
    config = TrainConfig(motion=motion, out=str(out), workers=1, envs_per_worker=4, init="rsi", samples=256, seed=5,
                         checkpoint_every=1, plot_every=0, runner="in_process")
    config.ppo.batch_size = 256
    config.ppo.minibatch_size = 128
    config.ppo.policy_hidden = (32, 32)
    config.ppo.value_hidden = (32,)
    Trainer(config, progress=False).run()


@pytest.fixture(scope="module")
def library(tmp_path_factory):
    root = tmp_path_factory.mktemp("library")
    runs = {"deepmimic:walk": root / "walk", "deepmimic:run": root / "run"}
    for motion, out in runs.items():
        tiny_run(out, motion)
    return runs


def decode(path) -> np.ndarray:
    with imageio.get_reader(path) as reader:
        return np.stack(list(reader.iter_data()))


def test_complete_a_real_video_frame(still_image, pose_models, library, tmp_path, capsys):
    out = tmp_path / "predicted.mp4"
    run_dirs = [str(p) for p in library.values()]
    code = main(["complete", str(still_image), "--library", *run_dirs, "--out", str(out), "--seconds", str(SECONDS),
                 "--pose-models", str(pose_models), "--height", str(HEIGHT), "--width", str(SIM_WIDTH)])
    assert code == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])

    # The choice: the library entry with the smallest distance, a real frame of its motion.
    assert [entry["run"] for entry in summary["library"]] == run_dirs
    assert [entry["motion"] for entry in summary["library"]] == list(library)
    best = min(summary["library"], key=lambda entry: entry["distance"])
    assert {k: summary[k] for k in best} == best
    assert 0.0 <= summary["phase"] < 1.0 and summary["frame"] >= 0
    # 12 joints + the root: a human pose fitted from the image is within ~1 rad per rotation of
    # some locomotion frame; an unfitted or garbage pose would not be.
    assert 0.0 < summary["distance"] < 13.0

    # The video: one frame after the reset and one per control step, the image beside the simulation.
    steps = round(SECONDS * 30)
    assert not summary["fell"] and summary["steps"] == steps
    frames = decode(out)
    assert len(frames) == summary["frames"] == steps + 1
    panel = int(round(1080 * HEIGHT / 1920)) // 2 * 2
    assert frames.shape[1:] == (HEIGHT, panel + SIM_WIDTH, 3) == (summary["height"], summary["width"], 3)
    image, simulation = frames[..., :panel, :].astype(int), frames[..., panel:, :].astype(int)
    # Left: the still image (constant over time, the decoded frame it was cut from).
    original = cv2.resize(cv2.cvtColor(cv2.imread(str(still_image)), cv2.COLOR_BGR2RGB), (panel, HEIGHT),
                          interpolation=cv2.INTER_AREA).astype(int)
    assert np.abs(image[-1] - image[0]).mean() < 3.0
    assert np.abs(image[0, HEIGHT // 2:] - original[HEIGHT // 2:]).mean() < 12.0  # lower half: no caption
    # Right: the character moves (the captions' clock changes too, so compare below them).
    body = slice(HEIGHT // 3, HEIGHT)
    assert np.abs(simulation[-1, body] - simulation[0, body]).mean() > 1.0
    assert simulation[0, body].std() > 10.0  # not a blank render
    assert not [p for p in tmp_path.iterdir() if p.name != out.name]  # no temp file left


def test_an_image_without_a_person_is_refused(pose_models, library, tmp_path, capsys):
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((480, 640, 3), 200, np.uint8))
    out = tmp_path / "never.mp4"
    code = main(["complete", str(blank), "--library", *map(str, library.values()), "--out", str(out),
                 "--pose-models", str(pose_models)])
    assert code == 2
    assert capsys.readouterr().err.strip() == f"sfv: {blank}: no person detected"
    assert [p.name for p in tmp_path.iterdir()] == ["blank.png"]
