"""A walker's missed support: short gaps with no foot down, at a walking pace, get the likelier foot."""
import numpy as np

from services.contacts.support import FLIGHT_PACE, MAX_GAP_S, fill_missed_support, hip_pace, keypoint_span

FPS = 30.0


def _gait(frames: int = 60) -> tuple[np.ndarray, np.ndarray]:
    """Flags and probabilities of a walk whose left stance (frames 20-29) the network half saw."""
    probabilities = np.zeros((frames, 2))
    probabilities[:20, 0] = 0.9
    probabilities[20:30, 1] = 0.9
    probabilities[30:, 0] = 0.9
    probabilities[24:28, 1] = 0.3  # four frames at 0.3: no foot down
    return probabilities >= 0.5, probabilities


def test_a_short_gap_at_a_walking_pace_gets_the_likelier_foot():
    flags, probabilities = _gait()
    assert not flags[24:28].any()
    filled, runs = fill_missed_support(flags, probabilities, np.full(60, 0.8), FPS)
    assert runs == [(24, 27)]
    assert filled[24:28, 1].all() and not filled[24:28, 0].any()  # the left foot, the likelier one
    np.testing.assert_array_equal(np.delete(filled, range(24, 28), axis=0), np.delete(flags, range(24, 28), axis=0))


def test_a_runner_keeps_the_flight_and_a_long_gap_is_kept():
    flags, probabilities = _gait()
    assert fill_missed_support(flags, probabilities, np.full(60, FLIGHT_PACE + 0.5), FPS)[1] == []
    long_gap = flags.copy()
    gap = int(MAX_GAP_S * FPS) + 2  # a jump's flight
    long_gap[24:24 + gap] = False
    assert fill_missed_support(long_gap, probabilities, np.full(60, 0.8), FPS)[1] == []


def test_a_few_frames_of_jumping_keypoints_do_not_make_a_walk_a_run():
    """Where the park walker passes the man on the box her hip keypoints jump for a few frames."""
    flags, probabilities = _gait()
    pace = np.full(60, 0.8)
    pace[22:25] = 3.7
    assert fill_missed_support(flags, probabilities, pace, FPS)[1] == [(24, 27)]


def test_pace_is_in_keypoint_spans_per_second():
    frames = 31
    points = np.zeros((frames, 17, 2))
    points[:, :, 1] = np.linspace(0.0, 400.0, 17)  # a body 400 px tall
    points[:, :, 0] = np.arange(frames)[:, None] * 10.0  # 10 px a frame: 300 px/s
    confidence = np.ones((frames, 17))
    span = keypoint_span(points, confidence)
    assert span == 400.0
    np.testing.assert_allclose(hip_pace(points, [0, 1], span, FPS), 300.0 / 400.0)
