"""Real BlazePose runs on real video (../shared's Pose2Sim clip) and on clips generated here.

Models come from ../shared/models/blazepose (allowed for tests) or the `sfv models fetch`
cache; tests skip cleanly when neither the models nor ../shared is there.
"""
from pathlib import Path

import cv2
import numpy as np
import pytest

from learner.errors import SfvError
from services.cli import main
from services.pose import PoseConfig, PoseTrack, estimate_video, resolve_model_files
from services.pose.detector import PoseDetector
from services.pose.estimator import estimate_chunk, rotate_frame
from services.pose.landmarks import LandmarkModel
from services.pose.models import DETECTOR_FILE, LANDMARK_FILE
from services.pose.openpose import load_openpose_frame, matched_joint_errors
from services.pose.roi import roi_from_alignment_points
from services.pose.video import read_frames
from tests.video_helpers import write_clip

SHARED = Path(__file__).resolve().parents[3].parent / "shared"
CLIP = SHARED / "data" / "video" / "pose2sim_balancing"
# Measured on cam01 frames 0-19: mean 16.1 px, worst frame 18.5 px (person ~900 px tall,
# OpenPose BODY_25B on the same frames; the two models place hips differently).
MEAN_ERROR_BOUND_PX = 25.0
FRAME_ERROR_BOUND_PX = 30.0


@pytest.fixture(scope="module")
def cam01():
    if not (CLIP / "cam01.mp4").is_file():
        pytest.skip("../shared absent")
    return CLIP / "cam01.mp4"


@pytest.fixture(scope="module")
def person_frames(cam01):
    """First 12 frames of the real clip at half size (540x960), RGB."""
    return [cv2.resize(frame, (540, 960), interpolation=cv2.INTER_AREA) for _, frame in read_frames(cam01, 0, 12)]


@pytest.mark.shared
def test_real_clip_finds_the_person_close_to_openpose(cam01, models_dir):
    chunk = estimate_chunk(cam01, 0, 20, resolve_model_files(models_dir))
    assert len(chunk) == 20 and chunk.valid.all()
    openpose = [load_openpose_frame(CLIP / "pose" / "cam01_json" / f"cam01.{t:04d}.json") for t in range(20)]
    errors = np.array([matched_joint_errors(chunk.keypoints2d[t], openpose[t]) for t in range(20)])
    per_frame = np.nanmean(errors, axis=1)
    assert np.nanmean(errors) < MEAN_ERROR_BOUND_PX
    assert per_frame.max() < FRAME_ERROR_BOUND_PX
    # world landmarks: metres, hip-centred, y down (head above hips, ankles below)
    hips = chunk.world3d[:, [23, 24]].mean(axis=1)
    assert np.abs(hips).max() < 0.05
    assert (chunk.world3d[:, 0, 1] < -0.3).all() and (chunk.world3d[:, [27, 28], 1] > 0.5).all()


@pytest.mark.shared
def test_onnx_and_tflite_landmark_backends_agree(cam01, models_dir):
    onnx = SHARED / "models" / "blazepose" / "pose_landmark_full.onnx"
    if not onnx.is_file():
        pytest.skip("../shared absent")
    files = resolve_model_files(models_dir)
    detector = PoseDetector(files.detector)
    tflite_model, onnx_model = LandmarkModel(files.landmark), LandmarkModel(onnx)
    for _, frame in read_frames(cam01, 0, 4):
        detection = detector.detect(frame)
        roi = roi_from_alignment_points(detection.keypoints[0], detection.keypoints[1])
        from_tflite, from_onnx = tflite_model.estimate(frame, roi), onnx_model.estimate(frame, roi)
        assert from_onnx.presence > 0.5
        # same crop in, so only the runtimes differ (tf2onnx conversion: ~1e-3 px)
        assert np.abs(from_onnx.keypoints - from_tflite.keypoints).max() < 0.5
        assert np.abs(from_onnx.world - from_tflite.world).max() < 1e-3
        assert np.abs(from_onnx.visibility - from_tflite.visibility).max() < 1e-3


@pytest.mark.shared
def test_blanked_frames_are_filled_and_counted(tmp_path, person_frames, models_dir):
    frames = [f.copy() for f in person_frames]
    blank = [4, 5, 6, 11]
    for index in blank:
        frames[index][:] = 128
    track = estimate_video(write_clip(tmp_path / "gaps.avi", frames), models_dir=models_dir, chunk_frames=5)
    expected_valid = np.ones(12, bool)
    expected_valid[blank] = False
    np.testing.assert_array_equal(track.valid, expected_valid)
    assert track.filled_frames == 4 and len(track) == 12 and track.fps == pytest.approx(60.0)
    assert track.image_size == (540, 960)
    np.testing.assert_allclose(track.keypoints2d[5], (track.keypoints2d[3] + track.keypoints2d[7]) / 2, atol=1e-3)
    np.testing.assert_allclose(track.world3d[4], track.world3d[3] + (track.world3d[7] - track.world3d[3]) / 4, atol=1e-5)
    np.testing.assert_array_equal(track.keypoints2d[11], track.keypoints2d[10])
    assert (track.confidence[blank] == 0).all() and (track.confidence[~expected_valid] == 0).all()


@pytest.mark.shared
def test_upside_down_clip_is_mapped_back_to_its_own_frame(tmp_path, person_frames, models_dir):
    frames = person_frames[:4]
    upright = estimate_video(write_clip(tmp_path / "up.avi", frames), models_dir=models_dir)
    flipped_frames = [rotate_frame(f, 180)[0] for f in frames]
    # rotation_threshold > 1 makes every frame also try the 90/180/270 rotated copies
    flipped = estimate_video(write_clip(tmp_path / "down.avi", flipped_frames), models_dir=models_dir,
                             config=PoseConfig(rotation_threshold=1.01))
    assert flipped.valid.all() and set(flipped.rotation_used) <= {0, 90, 180, 270}
    _, back = rotate_frame(frames[0], 180)
    in_upright_frame = flipped.keypoints2d @ back[:, :2].T + back[:, 2]
    assert np.linalg.norm(in_upright_frame - upright.keypoints2d, axis=-1).mean() < 6.0
    # 3D x and y turn with the image, z does not
    np.testing.assert_allclose(flipped.world3d[..., :2], -upright.world3d[..., :2], atol=0.12)


def test_blank_video_is_a_no_person_error(tmp_path, models_dir):
    frames = [np.full((240, 320, 3), 40 * i, np.uint8) for i in range(5)]
    with pytest.raises(SfvError, match=r"blank\.avi: no person detected in any of 5 frames"):
        estimate_video(write_clip(tmp_path / "blank.avi", frames, fps=30.0), models_dir=models_dir)


def test_bad_video_files_are_clear_errors(tmp_path, models_dir):
    text = tmp_path / "notes.mp4"
    text.write_text("this is not a video\n")
    with pytest.raises(SfvError, match=r"notes\.mp4: not a readable video"):
        estimate_video(text, models_dir=models_dir)
    with pytest.raises(SfvError, match=r"absent\.mp4: no such video file"):
        estimate_video(tmp_path / "absent.mp4", models_dir=models_dir)
    empty = tmp_path / "empty.avi"
    cv2.VideoWriter(str(empty), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, (64, 48)).release()
    with pytest.raises(SfvError, match=r"empty\.avi: (video has no decodable frames|not a readable video)"):
        estimate_video(empty, models_dir=models_dir)


def test_unreadable_or_missing_model_is_a_clear_error(tmp_path, models_dir):
    clip = write_clip(tmp_path / "grey.avi", [np.full((48, 64, 3), 128, np.uint8)] * 2)
    broken = tmp_path / "models"
    broken.mkdir()
    (broken / DETECTOR_FILE).write_bytes(b"\x00garbage, not a flatbuffer" * 10)
    (broken / LANDMARK_FILE).write_bytes((models_dir / LANDMARK_FILE).read_bytes())
    with pytest.raises(SfvError, match=r"pose_detection\.tflite: cannot load TFLite model .*sfv models fetch"):
        estimate_video(clip, models_dir=broken)
    (broken / DETECTOR_FILE).unlink()
    with pytest.raises(SfvError, match=r"pose_detection\.tflite: pose model not found; run `sfv models fetch`"):
        estimate_video(clip, models_dir=broken)
    # a landmark model given where the detector belongs is caught by its shape, not run blindly
    (broken / DETECTOR_FILE).write_bytes((models_dir / LANDMARK_FILE).read_bytes())
    with pytest.raises(SfvError, match="not a BlazePose person detector"):
        estimate_video(clip, models_dir=broken)


@pytest.mark.shared
def test_cli_writes_a_track_and_rejects_bad_input(tmp_path, person_frames, models_dir, capsys):
    clip = write_clip(tmp_path / "person.avi", person_frames[:3])
    out = tmp_path / "person_pose.npz"
    assert main(["pose", str(clip), "--out", str(out), "--serial", "--pose-models", str(models_dir)]) == 0
    track = PoseTrack.load(out)
    assert len(track) == 3 and track.valid.all()
    assert "3 frames, person in 3" in capsys.readouterr().out
    bad_out = tmp_path / "bad_pose.npz"
    assert main(["pose", str(tmp_path / "missing.mp4"), "--out", str(bad_out), "--serial", "--pose-models", str(models_dir)]) == 2
    assert "sfv: " in capsys.readouterr().err and not bad_out.exists()
