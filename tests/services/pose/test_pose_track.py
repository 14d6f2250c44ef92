"""PoseTrack storage and gap filling (no model files needed)."""
import numpy as np
import pytest

from learner.errors import SfvError
from services.pose.track import KEYPOINT_NAMES, PoseTrack, fill_gaps


def _track(frames=6, seed=0):
    rng = np.random.default_rng(seed)
    valid = np.ones(frames, bool)
    valid[2] = False
    return PoseTrack(
        fps=60.0, image_size=(1080, 1920),
        keypoints2d=rng.uniform(0, 1000, (frames, 33, 2)).astype(np.float32),
        confidence=rng.uniform(0, 1, (frames, 33)).astype(np.float32),
        world3d=rng.normal(0, 0.5, (frames, 33, 3)).astype(np.float32),
        valid=valid, presence=rng.uniform(0.5, 1, frames).astype(np.float32),
        rotation_used=np.array([0, 90, 0, 180, 270, 0][:frames], np.int16), filled_frames=1,
    )


def test_fill_gaps_is_linear_inside_and_constant_at_the_ends():
    values = np.array([[0.0], [99.0], [4.0], [99.0], [99.0], [10.0], [99.0]])
    valid = np.array([False, False, True, False, False, True, False])
    filled = fill_gaps(values, valid)
    np.testing.assert_allclose(filled[:, 0], [4, 4, 4, 6, 8, 10, 10])


def test_fill_gaps_keeps_valid_frames_and_shape():
    values = np.random.default_rng(1).normal(size=(5, 33, 3)).astype(np.float32)
    valid = np.array([True, False, True, True, False])
    filled = fill_gaps(values, valid)
    assert filled.shape == values.shape and filled.dtype == values.dtype
    np.testing.assert_array_equal(filled[valid], values[valid])
    np.testing.assert_allclose(filled[1], (values[0] + values[2]) / 2, rtol=1e-6)
    np.testing.assert_array_equal(filled[4], values[3])


def test_save_load_round_trip(tmp_path):
    track = _track()
    path = track.save(tmp_path / "clip.npz")
    loaded = PoseTrack.load(path)
    assert loaded.fps == track.fps and loaded.image_size == track.image_size
    assert loaded.filled_frames == 1 and loaded.keypoint_names == KEYPOINT_NAMES
    for name in ("keypoints2d", "confidence", "world3d", "valid", "presence", "rotation_used"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(track, name))
    assert [p.name for p in tmp_path.iterdir()] == ["clip.npz"]  # no temp file left behind


def test_keypoint_names_are_blazepose_order():
    assert len(KEYPOINT_NAMES) == 33
    assert KEYPOINT_NAMES[0] == "nose" and KEYPOINT_NAMES[23] == "left_hip" and KEYPOINT_NAMES[-1] == "right_foot_index"


def test_save_into_missing_directory_fails_cleanly(tmp_path):
    with pytest.raises(SfvError, match="does not exist"):
        _track().save(tmp_path / "nope" / "clip.npz")


def test_load_rejects_non_npz_and_incomplete_files(tmp_path):
    junk = tmp_path / "junk.npz"
    junk.write_text("not a zip")
    with pytest.raises(SfvError, match="junk.npz"):
        PoseTrack.load(junk)
    partial = tmp_path / "partial.npz"
    np.savez(partial, fps=30.0)
    with pytest.raises(SfvError, match="missing array"):
        PoseTrack.load(partial)
    with pytest.raises(SfvError, match="no such pose track"):
        PoseTrack.load(tmp_path / "absent.npz")


def test_load_rejects_inconsistent_shapes(tmp_path):
    track = _track()
    track.world3d = track.world3d[:, :, :2]
    track.save(tmp_path / "bad.npz")
    with pytest.raises(SfvError, match="world3d has shape"):
        PoseTrack.load(tmp_path / "bad.npz")
