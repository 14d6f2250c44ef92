"""`sfv reconstruct` and `sfv render-motion` on real video (../shared's Pose2Sim clip) and on bad input.

The real-video tests need ../shared (the clip and the BlazePose models, or the `sfv models
fetch` cache) and skip cleanly without it.
"""
from pathlib import Path

import cv2
import imageio.v3 as iio
import numpy as np
import pytest

from actors.motion.formats.io import load_motion, save_motion
from learner.errors import SfvError
from services.cli import main
from services.pose.video import read_frames
from services.reconstruction.synthetic import make_clip
from services.render.offscreen import gl_context
from tests.video_helpers import write_clip

SHARED = Path(__file__).resolve().parents[3].parent / "shared"
CLIP = SHARED / "data" / "video" / "pose2sim_balancing" / "cam01.mp4"
FRAMES = 30
HALF_SIZE = (540, 960)


@pytest.fixture(scope="module")
def real_clip(tmp_path_factory):
    """The first 30 frames of the Pose2Sim clip's camera 1 at half size."""
    if not CLIP.is_file():
        pytest.skip("../shared absent")
    frames = [cv2.resize(frame, HALF_SIZE, interpolation=cv2.INTER_AREA) for _, frame in read_frames(CLIP, 0, FRAMES)]
    return write_clip(tmp_path_factory.mktemp("clip") / "balancing.avi", frames)


@pytest.fixture(scope="module")
def real_motion(real_clip, models_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("motion") / "balancing.npz"
    track = out.with_name("balancing_track.npz")
    code = main(["reconstruct", str(real_clip), "--out", str(out), "--pose-models", str(models_dir),
                 "--iterations", "80", "--save-track", str(track)])
    assert code == 0
    return out, track


@pytest.fixture(scope="module")
def can_render():
    try:
        gl_context(16, 16).free()
    except SfvError as exc:
        pytest.skip(f"MuJoCo cannot render here: {exc}")


def leftovers(directory: Path) -> list[str]:
    return sorted(p.name for p in directory.iterdir())


@pytest.mark.integration
def test_reconstruct_real_video_with_ray(real_motion):
    out, _ = real_motion
    motion = load_motion(out)
    assert motion.num_frames == FRAMES and motion.name == "balancing"
    assert motion.fps == pytest.approx(60.0, rel=1e-3)
    keypoints3d = motion.extras["keypoints3d"]
    assert keypoints3d.shape == (FRAMES, 12, 3) and np.isfinite(keypoints3d).all()
    # The humanoid stands on the ground (z up) and its head-to-foot extent is a person's.
    assert keypoints3d[..., 2].min() >= 0.0 and 1.0 < np.ptp(keypoints3d[..., 2], axis=1).mean() < 1.6
    # Its joints project back onto the person: a few percent of the person's height (~450 px here).
    assert float(np.mean(motion.extras["reprojection_error_px"])) < 20.0


@pytest.mark.integration
def test_reconstruct_from_a_saved_track_in_process(real_clip, real_motion, tmp_path):
    _, track = real_motion
    out = tmp_path / "again.npz"
    assert main(["reconstruct", str(real_clip), "--out", str(out), "--track", str(track), "--iterations", "5", "--serial"]) == 0
    assert load_motion(out).num_frames == FRAMES


@pytest.mark.integration
def test_render_motion_writes_the_side_by_side_video(real_clip, real_motion, can_render, tmp_path):
    out, _ = real_motion
    video = tmp_path / "side_by_side.mp4"
    assert main(["render-motion", str(out), "--video", str(real_clip), "--out", str(video), "--height", "240"]) == 0
    frames = iio.imread(video)
    assert frames.shape == (FRAMES, 240, 2 * 136, 3)  # 540x960 scaled to 240 high: 135 -> 136 px wide (even)
    rendered = frames[:, :, 136:]
    assert rendered.std() > 10.0  # the humanoid and the floor, not an empty frame
    assert leftovers(tmp_path) == ["side_by_side.mp4"]


def test_missing_video_is_a_one_line_error_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "motion.npz"
    assert main(["reconstruct", str(tmp_path / "nope.mp4"), "--out", str(out), "--serial"]) == 2
    message = capsys.readouterr().err.strip()
    assert message.count("\n") == 0 and "nope.mp4" in message and "no such video" in message
    assert leftovers(tmp_path) == []


def test_a_file_that_is_not_a_video_is_rejected(tmp_path, capsys):
    fake = tmp_path / "notes.mp4"
    fake.write_text("this is not a video\n")
    assert main(["reconstruct", str(fake), "--out", str(tmp_path / "motion.npz"), "--serial"]) == 2
    assert "notes.mp4" in capsys.readouterr().err
    assert leftovers(tmp_path) == ["notes.mp4"]


def test_a_video_without_frames_is_rejected(tmp_path, capsys):
    empty = tmp_path / "empty.avi"
    writer = cv2.VideoWriter(str(empty), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, (64, 64))
    writer.release()
    assert main(["reconstruct", str(empty), "--out", str(tmp_path / "motion.npz"), "--serial"]) == 2
    assert "empty.avi" in capsys.readouterr().err
    assert not (tmp_path / "motion.npz").exists()


def test_a_video_without_a_person_is_rejected(models_dir, tmp_path, capsys):
    grey = write_clip(tmp_path / "grey.avi", [np.full((256, 192, 3), 128, np.uint8)] * 6)
    assert main(["reconstruct", str(grey), "--out", str(tmp_path / "motion.npz"), "--pose-models", str(models_dir),
                 "--serial"]) == 2
    message = capsys.readouterr().err
    assert "grey.avi" in message and "no person" in message
    assert leftovers(tmp_path) == ["grey.avi"]


def test_render_motion_needs_a_reconstructed_motion(tmp_path, capsys):
    clip = make_clip(frames=4)
    video = write_clip(tmp_path / "clip.avi", [np.zeros((480, 640, 3), np.uint8)] * 4)
    plain = tmp_path / "plain.npz"
    from actors.motion.reference_motion import ReferenceMotion

    save_motion(ReferenceMotion("plain", np.arange(4) / 30.0, clip.root_pos, clip.root_quat, clip.joint_quats), plain)
    assert main(["render-motion", str(plain), "--video", str(video), "--out", str(tmp_path / "out.mp4")]) == 2
    assert "sfv reconstruct" in capsys.readouterr().err
    assert not (tmp_path / "out.mp4").exists()
