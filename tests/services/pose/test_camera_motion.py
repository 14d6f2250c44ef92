"""Camera motion from the background: homographies, pan/tilt/zoom, the static/moving decision."""
import cv2
import numpy as np
import pytest

from learner.errors import SfvError
from services.pose.camera_motion import CameraMotionEstimator
from services.pose.camera_path import camera_path, decide_camera
from services.pose.pipeline import estimate_people
from tests.people_clips import CAM01, moving_camera_clip, two_people_clip


def _texture(seed=0, size=(480, 640)):
    rng = np.random.default_rng(seed)
    small = rng.integers(0, 255, (size[0] // 8, size[1] // 8, 3), dtype=np.uint8)
    return cv2.GaussianBlur(cv2.resize(small, size[::-1], interpolation=cv2.INTER_CUBIC), (0, 0), 1.0)


def _warped(image, zoom, shift):
    centre = (np.array(image.shape[1::-1], float) - 1) / 2
    matrix = np.array([[zoom, 0, (1 - zoom) * centre[0] + shift[0]], [0, zoom, (1 - zoom) * centre[1] + shift[1]]])
    return cv2.warpAffine(image, matrix, image.shape[1::-1], flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)


def test_a_known_shift_and_zoom_of_a_textured_view_is_recovered():
    base = _texture()
    estimator = CameraMotionEstimator()
    identity, _ = estimator.process(base, [])
    np.testing.assert_array_equal(identity, np.eye(3))
    homography, inliers = estimator.process(_warped(base, 1.02, (-4.0, 2.0)), [])
    assert inliers > 50
    path = camera_path(np.stack([identity, homography]), (640, 480))
    # content moved left 4 px and down 2 px: the view moved right 4 and up 2, zooming in 2%
    assert path.pan_px[1] == pytest.approx(4.0, abs=0.15) and path.tilt_px[1] == pytest.approx(-2.0, abs=0.15)
    assert path.zoom[1] == pytest.approx(1.02, abs=2e-3) and path.tracked.all()


def test_people_boxes_are_left_out_and_a_blank_view_is_untracked():
    base = _texture(1)
    moved = base.copy()
    moved[100:400, 200:440] = np.roll(base[100:400, 200:440], 12, axis=1)  # a "person" moving inside its box
    estimator = CameraMotionEstimator()
    estimator.process(base, [np.array([200.0, 100.0, 440.0, 400.0])])
    homography, _ = estimator.process(moved, [np.array([200.0, 100.0, 440.0, 400.0])])
    np.testing.assert_allclose(homography, np.eye(3), atol=2e-3)
    blank = CameraMotionEstimator()
    blank.process(np.full((240, 320, 3), 90, np.uint8), [])
    homography, count = blank.process(np.full((240, 320, 3), 90, np.uint8), [])
    assert np.isnan(homography).all() and count == 0


def test_the_decision_follows_the_flag_and_refuses_an_untrackable_view():
    still = camera_path(np.repeat(np.eye(3)[None], 10, axis=0), (640, 480))
    assert decide_camera("auto", still, 640, "v.mp4") is False
    assert decide_camera("moving", still, 640, "v.mp4") is True
    assert decide_camera("auto", None, 640, "old_track.npz") is False  # tracks made before camera tracking
    pan = np.repeat(np.eye(3)[None], 10, axis=0)
    pan[1:, 0, 2] = -3.0  # content 3 px left per frame: 27 px over the clip, over 2% of 640
    assert decide_camera("auto", camera_path(pan, (640, 480)), 640, "v.mp4") is True
    lost = np.full((10, 3, 3), np.nan)
    with pytest.raises(SfvError, match=r"v\.mp4: no background could be tracked in 9 of 9 frames"):
        decide_camera("auto", camera_path(lost, (640, 480)), 640, "v.mp4")
    assert decide_camera("static", camera_path(lost, (640, 480)), 640, "v.mp4") is False
    with pytest.raises(SfvError, match="--camera 'wobbly'"):
        decide_camera("wobbly", still, 640, "v.mp4")


@pytest.mark.shared
def test_a_synthetic_pan_and_zoom_over_the_real_video_is_measured(tmp_path, models_dir):
    if not CAM01.is_file():
        pytest.skip("../shared absent")
    clip = moving_camera_clip(tmp_path / "pan.avi")
    people = estimate_people(clip.path, models_dir=models_dir, chunk_frames=20)
    path = camera_path(people.camera_homography, people.image_size)
    assert path.untracked_frames == 0
    # measured: 0.019 px pan, 0.024 px tilt, 1.3e-4 zoom mean error; true 1.86 px, 0.93 px, 1.0047 a frame
    assert np.abs(path.pan_px - clip.pan_px)[1:].mean() < 0.1 and np.abs(path.tilt_px - clip.tilt_px)[1:].mean() < 0.1
    assert np.abs(path.zoom - clip.zoom)[1:].max() < 2e-3
    assert path.total_zoom[-1] == pytest.approx(np.prod(clip.zoom), rel=0.01)
    assert decide_camera("auto", path, people.image_size[0], "pan.avi") is True


@pytest.mark.shared
def test_a_still_view_with_a_person_walking_out_is_static(tmp_path, models_dir):
    if not CAM01.is_file():
        pytest.skip("../shared absent")
    clip = two_people_clip(tmp_path / "two.avi", frames=80)
    people = estimate_people(clip.path, models_dir=models_dir, chunk_frames=40)
    path = camera_path(people.camera_homography, people.image_size)
    assert np.abs(path.offset_px).max() < 2.0
    assert decide_camera("auto", path, people.image_size[0], "two.avi") is False
