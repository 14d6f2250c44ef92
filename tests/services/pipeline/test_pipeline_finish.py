"""The static pipeline's finishing step (`services/pipeline/finish.py`) on a synthetic
reconstruction: a standing body whose reference slides 0.3 m/s sideways, seen by a known
camera in a 60 fps video, and a run trained on it for a few hundred samples."""
from __future__ import annotations

import json

import numpy as np
import pytest

from actors.character.humanoid3d import Humanoid
from actors.character.state import StateLayout
from actors.motion.formats.io import load_motion, save_motion
from actors.motion.reference_motion import ReferenceMotion
from learner.errors import SfvError
from services.pipeline.metrics import project_points
from services.pipeline.rollout import body_kinematics
from tests.video_helpers import write_clip

STAND_HEIGHT = 0.885  # the rest pose's feet just touch the floor
FPS, FRAMES, SLIDE = 60.0, 61, 0.3
ROTATION = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], float)  # looking along +y, image y down
POSITION = np.array([0.0, -4.0, 1.0])
INTRINSICS = np.array([[300.0, 0, 79.5], [0, 300.0, 119.5], [0, 0, 1]])
IMAGE = (160, 240)


def reconstruction_like() -> ReferenceMotion:
    """What `sfv reconstruct` writes for a static camera, made from a known motion and camera."""
    frames = FRAMES
    joint_rot = np.zeros((frames, 12, 4))
    joint_rot[..., 0] = 1.0
    root_rot = np.zeros((frames, 4))
    root_rot[:, 0] = 1.0
    times = np.arange(frames) / FPS
    root_pos = np.stack((SLIDE * times, np.zeros(frames), np.full(frames, STAND_HEIGHT)), axis=-1)
    motion = ReferenceMotion("clip", times, root_pos, root_rot, joint_rot, loop=False)
    humanoid = Humanoid()
    layout = StateLayout(humanoid)
    qpos, qvel = np.zeros((frames, humanoid.model.nq)), np.zeros(humanoid.model.nv)
    for k in range(frames):
        layout.pose_to_qpos_qvel(motion.sample(times[k]), qpos[k], qvel)
    joints = body_kinematics(humanoid, qpos).joints
    motion.extras.update(
        keypoint_names=np.array(["RHip", "RKnee", "RAnkle", "LHip", "LKnee", "LAnkle", "RShoulder", "RElbow", "RWrist",
                                 "LShoulder", "LElbow", "LWrist"]),
        keypoints3d=joints, keypoints2d=project_points(joints, ROTATION, POSITION, INTRINSICS),
        confidence=np.full((frames, 12), 0.9), fps=np.array(FPS), camera_rotation=ROTATION, camera_position=POSITION,
        camera_intrinsics=INTRINSICS, image_size=np.array(IMAGE), video_start_frame=np.array(0))
    return motion


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """(directory, motion path, video path, run directory): a run trained a few hundred samples."""
    from actors.envs.imitation_env import EnvConfig
    from services.training.config import TrainConfig
    from services.training.driver import Trainer

    root = tmp_path_factory.mktemp("pipe")
    motion_path = save_motion(reconstruction_like(), root / "motion.npz")
    frames = [np.full((IMAGE[1], IMAGE[0], 3), 40 + 2 * k, np.uint8) for k in range(FRAMES)]
    video = write_clip(root / "clip.avi", frames, fps=FPS)
    config = TrainConfig(motion=str(motion_path), out=str(root / "train"), workers=1, envs_per_worker=2, init="rsi",
                         samples=256, runner="in_process", eval_every=0, env=EnvConfig(residual_force=0.5))  # the pipeline's help
    config.ppo.batch_size, config.ppo.minibatch_size = 128, 128
    config.ppo.policy_hidden, config.ppo.value_hidden = (32,), (16,)
    Trainer(config, progress=False).run()
    return root, motion_path, video, root / "train"


@pytest.fixture(scope="module")
def finished(trained):
    """`sfv pipeline VIDEO --out DIR --finish-only` on the trained directory: (DIR, report, stdout lines)."""
    import contextlib
    import io

    from services.cli import main

    root, _, video, _ = trained
    stdout = io.StringIO()
    with contextlib.redirect_stdout(stdout):
        assert main(["pipeline", str(video), "--out", str(root), "--finish-only", "--quiet"]) == 0
    lines = stdout.getvalue().splitlines()
    return root, json.loads((root / "report.json").read_text()), lines


@pytest.mark.slow
def test_finishing_writes_the_files_and_a_report_that_adds_up(finished, trained):
    root, report, lines = finished
    names = {"simulated.npz", "simulated.bvh", "video.mp4", "overlay_strip.png", "overlay_strip_without_help.png", "report.json"}
    assert names <= {p.name for p in root.iterdir()}
    assert not [p for p in root.iterdir() if p.name.startswith(".")]  # no temp file left behind
    assert len(lines) == 9  # one result line per file, the outcome, the controller given, then the summary as JSON
    assert "without it: " in report["outcome"] and set(report["without_residual_force"]) == {"fell", "fell_at_s", "toppling", "normalized_return"}
    assert lines[-3] == report["outcome"] and report["outcome"].startswith(("completed: ", "fell at "))
    # No body-alone stage was trained: the controller is the helped one, judged with its help at zero.
    assert lines[-2] == report["controller"] and report["controller"].startswith("controller: train, with its help at zero: ")
    summary = json.loads(lines[-1])
    assert summary["fell"] == report["fell"] and summary["files"] == report["files"]
    assert all(path in line for path, line in zip(report["files"].values(), lines))
    # One frame per control step for the clip's second: 30 steps plus the first frame.
    assert report["frames"] == 31 and report["clip_seconds"] == pytest.approx(1.0)
    simulated = load_motion(str(root / "simulated.npz"))
    assert simulated.num_frames == report["frames"] and not simulated.loop
    np.testing.assert_allclose(simulated.root_pos[0], [0.0, 0.0, STAND_HEIGHT], atol=1e-9)  # the clip's first frame
    # The reference's own joints reproject onto the keypoints they were projected from, at every
    # control step: the steps are matched with the right video frames (every other one at 60 fps).
    assert report["reprojection_error_px"]["reference"]["max"] < 1e-3
    assert report["foot_skating_m_s"]["reference"] == pytest.approx(SLIDE, rel=1e-3)
    assert report["joint_position_error_m"]["per_frame"][0] == pytest.approx(0.0, abs=1e-6)
    assert len(report["joint_position_error_m"]["per_frame"]) == report["frames"]
    assert report["fell"] == (report["fell_at_s"] is not None)
    assert 0.0 <= report["normalized_return"] <= 1.0


@pytest.mark.slow
def test_the_report_and_sfv_eval_agree_on_the_first_frame_episode(finished, trained):
    from services.training.evaluation import evaluate_run

    root, report, _ = finished
    first = evaluate_run(trained[3], episodes=1)["first_frame"]
    assert first["fell"] == report["fell"]
    assert first["normalized_return"] == pytest.approx(report["normalized_return"], abs=1e-4)  # the report rounds
    if report["fell"]:
        assert first["episode_seconds"] == pytest.approx(report["fell_at_s"], abs=1e-3)


@pytest.mark.slow
def test_the_simulated_motion_is_a_motion_training_takes(finished):
    from actors.envs.imitation_env import EnvConfig, ImitationEnv
    from actors.motion.formats.bvh import load_bvh_motion

    root, report, _ = finished
    env = ImitationEnv(load_motion(str(root / "simulated.npz")), EnvConfig())
    env.reset(options={"init": "fsi"})
    assert env.track.start_steps == report["frames"] - 1
    bvh = load_bvh_motion(str(root / "simulated.bvh"))
    assert bvh.num_frames == report["frames"]


@pytest.mark.slow
def test_the_video_and_strip_have_the_expected_frames(finished):
    import cv2

    root, report, _ = finished
    capture = cv2.VideoCapture(str(root / "video.mp4"))
    count, last = 0, None
    while True:
        ok, frame = capture.read()
        if not ok:
            break
        count, last = count + 1, frame
    assert count == report["frames"]
    assert capture.get(cv2.CAP_PROP_FRAME_WIDTH) == 3 * 320  # three panels of the 160x240 video scaled to 480 high
    # report.json's outcome line in a band under the panels: text in it, nothing drawn over the pictures
    band = last[480:]
    assert 20 <= band.shape[0] <= 120 and (band.max(axis=-1) > 128).mean() > 0.01
    strip = cv2.imread(str(root / "overlay_strip.png"))
    assert strip.shape[:2] == (480, 6 * 320)  # six frames
    # The body alone: as many frames as its episode has (to its fall), at most six.
    alone = report["without_residual_force"]
    unaided = cv2.imread(str(root / "overlay_strip_without_help.png"))
    assert unaided.shape[0] == 480 and unaided.shape[1] % 320 == 0 and 1 <= unaided.shape[1] // 320 <= 6
    if not alone["fell"]:
        assert unaided.shape[1] == 6 * 320


@pytest.mark.slow
def test_the_strip_shows_the_simulated_character_where_the_camera_sees_it(finished):
    """The strip's frames are flat grey (40 + 2 k): pixels that differ are the overlay (humanoid,
    keypoints, caption). The standing humanoid at 4 m covers the middle of the frame, not its sides."""
    import cv2

    root, _, _ = finished
    strip = cv2.imread(str(root / "overlay_strip.png")).astype(int)
    tile = strip[:, 320:640]  # the second frame (video frame 12: grey 64)
    changed = np.abs(tile - 64).sum(axis=-1) > 30
    # The body seen from its side about the image's centre column: ~3000 px (its keypoints' lines alone ~500).
    assert changed[150:450, 140:190].sum() > 2000
    # The floor fills the lower half of the picture (camera 1 m up, looking level) but is not overlaid.
    assert changed[250:470, :40].mean() < 0.02 and changed[250:470, -40:].mean() < 0.02


def test_finish_only_without_an_earlier_run_is_a_one_line_error(tmp_path, capsys):
    from services.cli import main

    video = write_clip(tmp_path / "clip.avi", [np.zeros((24, 32, 3), np.uint8)] * 3)
    assert main(["pipeline", str(video), "--out", str(tmp_path / "empty"), "--finish-only"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("sfv: ") and "motion.npz" in err and "\n" not in err
    assert main(["pipeline", str(video), "--out", str(tmp_path), "--finish-only", "--camera", "moving"]) == 2
    assert "--finish-only" in capsys.readouterr().err


def test_a_motion_without_a_camera_is_a_one_line_error(tmp_path):
    from services.pipeline.finish import finish_static_run

    motion = reconstruction_like()
    del motion.extras["camera_rotation"]
    path = save_motion(motion, tmp_path / "motion.npz")
    with pytest.raises(SfvError, match=r"motion\.npz: motion has no camera_rotation"):
        finish_static_run(tmp_path, tmp_path / "clip.avi", path, tmp_path / "run", progress=False)
    with pytest.raises(SfvError, match="missing.npz"):
        finish_static_run(tmp_path, tmp_path / "clip.avi", tmp_path / "missing.npz", tmp_path / "run", progress=False)


@pytest.mark.slow
def test_resume_keeps_a_finished_training_and_trains_the_body_alone_on_the_helped_rollout(finished, trained, tmp_path,
                                                                                          capsys):
    import shutil

    from services.cli import main
    from services.training.run_dir import read_run_config, trained_samples

    root, report, _ = finished
    copy = tmp_path / "run"
    shutil.copytree(root, copy)
    helped_samples = trained_samples(copy / "train")
    small = ["--samples", "256", "--runner", "in_process", "--workers", "1", "--envs-per-worker", "2", "--init", "rsi",
             "--eval-every", "0", "--batch-size", "128"]
    assert main(["pipeline", str(trained[2]), "--out", str(copy), "--resume", "--body-alone", "always", "--quiet",
                 *small]) == 0
    said = capsys.readouterr().out
    assert trained_samples(copy / "train") == helped_samples and "(kept)" in said  # the helped training kept
    combined = json.loads((copy / "report.json").read_text())
    stage = combined["body_alone"]
    if report["fell"]:  # a helped controller that fell leaves no rollout of the whole clip to follow
        assert not stage["ran"] and "fell at" in stage["line"] and not (copy / "alone").exists()
        return
    # The second stage: the helped rollout's poses as the reference, trained with no wrench, played from
    # the first frame; the top report names it as the controller.
    alone = json.loads((copy / "alone" / "report.json").read_text())
    config = read_run_config(copy / "alone" / "train")
    assert stage["ran"] and config.env.residual_force == 0 and "without_residual_force" not in alone
    simulated = np.load(copy / "simulated.npz")
    reference = load_motion(str(copy / "alone" / "motion.npz"))
    np.testing.assert_allclose(reference.root_pos, simulated["root_pos"], atol=1e-6)
    assert stage["normalized_return"] == alone["normalized_return"]
    assert combined["controller"].startswith("controller: the body alone (alone/train, no help): ")
    assert combined["controller"] in said
