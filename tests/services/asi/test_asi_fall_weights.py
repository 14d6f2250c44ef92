"""Failure-weighted component choice: the running fall rate and the draw it weights."""
import numpy as np
import pytest

from services.asi.distribution import InitialStateDistribution, evenly_spaced_phases
from services.asi.fall_weights import FALL_RATE_HALF_LIFE, FallStats, component_weights, sampling_weights

K = 10


def falls_of_component(component: int, episodes_per_component: int = 50) -> FallStats:
    """Stats after a report in which `component` always fell and every other component never."""
    components = np.repeat(np.arange(K), episodes_per_component)
    return FallStats.empty(K).updated(components, components == component)


def test_first_episodes_give_the_plain_mean_and_old_ones_fade_with_the_half_life():
    stats = FallStats.empty(2).updated(np.array([0, 0, 0, 0, 1]), np.array([True, False, False, False, False]))
    np.testing.assert_allclose(stats.rates, [0.25, 0.0])  # no bias toward 0 in a young job
    never = np.zeros(int(FALL_RATE_HALF_LIFE), bool)
    aged = stats.updated(np.zeros(never.size, np.int64), never)
    # The first report's 4 episodes now weigh half: 0.5 falls over 2 + 100 episodes.
    np.testing.assert_allclose(aged.rates[0], 0.5 / (2 + FALL_RATE_HALF_LIFE), rtol=1e-12)
    assert aged.rates[1] == 0.0 and aged.episodes[1] == 1.0  # another component's episodes do not age it


def test_a_report_counts_independently_of_the_order_of_its_episodes():
    rng = np.random.default_rng(0)
    components, fell = rng.integers(K, size=200), rng.random(200) < 0.3
    order = rng.permutation(200)
    start = falls_of_component(2)
    a, b = start.updated(components, fell), start.updated(components[order], fell[order])
    np.testing.assert_array_equal(a.falls, b.falls)
    np.testing.assert_array_equal(a.episodes, b.episodes)


def test_stats_round_trip_through_bytes_and_none_reads_as_empty():
    stats = falls_of_component(3)
    back = FallStats.from_bytes(stats.to_bytes(), K)
    np.testing.assert_array_equal(back.falls, stats.falls)
    np.testing.assert_array_equal(back.episodes, stats.episodes)
    np.testing.assert_array_equal(FallStats.from_bytes(None, K).rates, np.zeros(K))


@pytest.mark.parametrize("beta", [0.25, 0.5, 1.0])
def test_one_falling_component_gets_the_floor_plus_beta(beta):
    weights = sampling_weights(falls_of_component(3).rates, beta)
    expected = np.full(K, (1 - beta) / K)
    expected[3] += beta
    np.testing.assert_allclose(weights, expected, rtol=1e-12)
    assert weights.sum() == pytest.approx(1.0)


def test_beta_zero_or_no_falls_is_the_papers_uniform_draw():
    assert sampling_weights(falls_of_component(3).rates, 0.0) is None
    assert sampling_weights(np.zeros(K), 0.7) is None
    np.testing.assert_array_equal(component_weights(falls_of_component(3).rates, 0.0), np.full(K, 0.1))


def test_weighted_draws_hit_component_3_at_its_weight():
    """20000 draws at beta .5: component 3 at .05 + .5 = .55. The count is binomial, std
    sqrt(.55 * .45 / 20000) = .0035; the seed is fixed, and the 4-std tolerance (.014) would
    hold for almost every other seed too (two-sided 6e-5), while the paper's uniform draw (.1)
    or a weight without the floor (.5) or beta (1.0) lies far outside it."""
    dist = InitialStateDistribution(evenly_spaced_phases(K), np.zeros((K, 2)), np.zeros((K, 2)))
    weights = sampling_weights(falls_of_component(3).rates, 0.5)
    _, components = dist.sample(np.random.default_rng(7), 20000, weights)
    share = np.bincount(components, minlength=K) / 20000
    assert abs(share[3] - 0.55) < 4 * np.sqrt(0.55 * 0.45 / 20000)
    others = np.delete(share, 3)
    assert np.all(np.abs(others - 0.05) < 4 * np.sqrt(0.05 * 0.95 / 20000))


def test_without_weights_the_draw_is_bit_identical_to_the_uniform_one():
    dist = InitialStateDistribution(evenly_spaced_phases(K), np.ones((K, 3)), np.zeros((K, 3)))
    states, components = dist.sample(np.random.default_rng(5), 100, None)
    rng = np.random.default_rng(5)
    expected_components = rng.integers(K, size=100).astype(np.int32)
    np.testing.assert_array_equal(components, expected_components)
    np.testing.assert_array_equal(states, dist.sample(np.random.default_rng(5), 100)[0])
