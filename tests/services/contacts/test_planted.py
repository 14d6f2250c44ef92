"""A foot standing still in a static camera's picture while the body travels is down."""
import numpy as np

from services.contacts.planted import LIFT_SPANS, MIN_TRAVEL_PACE, PLANTED_RATIO, planted_feet

FPS = 30.0
HIPS = [0, 1]
FEET = [[2, 3, 4], [5, 6, 7]]  # right heel, ankle, toe; left heel, ankle, toe
SPAN = 170.0  # pixels from the head point to the feet


def _runner(frames: int = 30, pace: float = 2.5, right_x: float = 100.0) -> np.ndarray:
    """(T, 9, 2) points of a body travelling right at `pace` spans/s: the right foot stays at
    `right_x` on the ground, the left swings past at twice the hips' speed, 0.2 spans higher."""
    step = pace * SPAN / FPS
    hips_x = 50.0 + step * np.arange(frames)
    points = np.zeros((frames, 9, 2))
    points[:, 0] = np.stack([hips_x - 5, np.full(frames, 200.0)], axis=1)
    points[:, 1] = np.stack([hips_x + 5, np.full(frames, 200.0)], axis=1)
    for offset, index in zip((-8.0, 0.0, 10.0), FEET[0]):
        points[:, index] = [right_x + offset, 300.0]
    for offset, index in zip((-8.0, 0.0, 10.0), FEET[1]):
        points[:, index, 0] = 2.0 * hips_x - 60.0 + offset
        points[:, index, 1] = 300.0 - 0.2 * SPAN
    points[:, 8] = np.stack([hips_x, np.full(frames, 300.0 - SPAN)], axis=1)  # the head: the span
    return points


def _seen(points: np.ndarray) -> np.ndarray:
    return np.ones(points.shape[:2])


def test_the_still_foot_under_a_travelling_body_is_planted_and_the_swinging_one_is_not():
    points = _runner()
    planted = planted_feet(points, _seen(points), FPS, HIPS, FEET)
    assert planted[:, 0].all()
    assert not planted[:, 1].any()


def test_a_body_that_does_not_travel_plants_nothing():
    """Standing, every foot is as still as the hips: stillness says nothing."""
    points = _runner(pace=MIN_TRAVEL_PACE / 2)
    points[:, FEET[1], 1] = 300.0  # both feet low
    assert not planted_feet(points, _seen(points), FPS, HIPS, FEET).any()


def test_a_foot_that_creeps_faster_than_the_ratio_is_not_planted():
    points = _runner(pace=2.5)
    creep = 1.2 * PLANTED_RATIO * 2.5 * SPAN / FPS  # pixels per frame
    points[:, FEET[0], 0] += creep * np.arange(len(points))[:, None]
    assert not planted_feet(points, _seen(points), FPS, HIPS, FEET)[:, 0].any()


def test_a_still_foot_held_above_the_other_or_unseen_is_not_planted():
    points = _runner()
    points[:, FEET[1], 1] = 300.0  # the left foot now low, so the right one held 2 x LIFT_SPANS above it
    points[:, FEET[0], 1] = 300.0 - 2 * LIFT_SPANS * SPAN
    assert not planted_feet(points, _seen(points), FPS, HIPS, FEET)[:, 0].any()
    points = _runner()
    confidence = _seen(points)
    confidence[:, FEET[0]] = 0.2
    assert not planted_feet(points, confidence, FPS, HIPS, FEET)[:, 0].any()


def test_a_repeated_frame_plants_nothing():
    """A frozen picture (a frame-rate conversion, a video's first frames) holds every point still."""
    points = _runner()
    points[:3] = points[3]  # the first four frames one picture
    planted = planted_feet(points, _seen(points), FPS, HIPS, FEET)
    assert not planted[:2].any()
    assert planted[5:, 0].all()
