"""The ASI distribution math: gradient, step, safeguards, sampling, paper initialisation."""
import numpy as np
import pytest

from services.asi.distribution import InitialStateDistribution, UpdateConfig, component_baseline, evenly_spaced_phases, nearest_frames

# Hand-computed case: D = 2, k = 2, N = 3 episodes.
#   component 0: mu = (0, 0), sigma = (1, 2);  component 1: mu = (1, 2), sigma = (0.5, 1)
#   e1: c=0, s=(1, 2),   R=3  -> z=(1, 1),  d mu = z/sigma = (1, 0.5), d log sigma = z^2-1 = (0, 0)
#   e2: c=0, s=(-1, 0),  R=1  -> z=(-1, 0), d mu = (-1, 0),            d log sigma = (0, -1)
#   e3: c=1, s=(1.5, 2), R=2  -> z=(1, 0),  d mu = (2, 0),             d log sigma = (0, -1)
PHASES = np.array([0.0, 0.5])
MEANS = np.array([[0.0, 0.0], [1.0, 2.0]])
STDS = np.array([[1.0, 2.0], [0.5, 1.0]])
STATES = np.array([[1.0, 2.0], [-1.0, 0.0], [1.5, 2.0]])
COMPONENTS = np.array([0, 0, 1])
RETURNS = np.array([3.0, 1.0, 2.0])


def hand_case() -> InitialStateDistribution:
    return InitialStateDistribution(PHASES, MEANS, np.log(STDS))


def test_gradient_matches_hand_computation_with_component_mean_baseline():
    # baselines: b0 = (3+1)/2 = 2, b1 = 2 -> advantages (+1, -1, 0); N = 3
    grad = hand_case().gradient(STATES, COMPONENTS, RETURNS, "component_mean")
    np.testing.assert_allclose(grad.means, [[2 / 3, 1 / 6], [0, 0]], atol=1e-15)
    np.testing.assert_allclose(grad.log_stds, [[0, 1 / 3], [0, 0]], atol=1e-15)


def test_gradient_matches_hand_computation_without_baseline():
    # component 0: 3*(1, .5) + 1*(-1, 0) = (2, 1.5); 3*(0, 0) + 1*(0, -1) = (0, -1)
    # component 1: 2*(2, 0) = (4, 0); 2*(0, -1) = (0, -2); all divided by N = 3
    grad = hand_case().gradient(STATES, COMPONENTS, RETURNS, "none")
    np.testing.assert_allclose(grad.means, [[2 / 3, 0.5], [4 / 3, 0]], atol=1e-15)
    np.testing.assert_allclose(grad.log_stds, [[0, -1 / 3], [0, -2 / 3]], atol=1e-15)


def test_raw_step_matches_hand_computation():
    config = UpdateConfig(step_size=0.3, max_step_fraction=0.0, min_std=1e-6, baseline="component_mean")
    after = hand_case().apply_update(STATES, COMPONENTS, RETURNS, config)
    np.testing.assert_allclose(after.means, [[0.2, 0.05], [1.0, 2.0]], atol=1e-15)
    np.testing.assert_allclose(after.log_stds, [[0.0, np.log(2) + 0.1], np.log([0.5, 1.0])], atol=1e-15)


def test_step_is_clipped_to_a_fraction_of_sigma():
    # raw step 3 * grad: means (2, 0.5) -> limit 0.5 * sigma = (0.5, 1) -> (0.5, 0.5); log-std (0, 1) -> (0, 0.5)
    config = UpdateConfig(step_size=3.0, max_step_fraction=0.5, min_std=1e-6)
    after = hand_case().apply_update(STATES, COMPONENTS, RETURNS, config)
    np.testing.assert_allclose(after.means[0], [0.5, 0.5], atol=1e-15)
    np.testing.assert_allclose(after.log_stds[0], [0.0, np.log(2) + 0.5], atol=1e-15)


def test_std_never_falls_below_the_floor():
    # baseline none: log-std gradient of component 1 is (0, -2/3); a huge step drives it to the floor
    config = UpdateConfig(step_size=100.0, max_step_fraction=0.0, min_std=0.25, baseline="none")
    after = hand_case().apply_update(STATES, COMPONENTS, RETURNS, config)
    assert after.stds[1, 1] == pytest.approx(0.25)
    assert np.all(after.stds >= 0.25 - 1e-12)


def test_non_finite_step_is_rejected():
    states = np.array([[1e300, 0.0]])
    before = InitialStateDistribution(np.array([0.0]), np.zeros((1, 2)), np.log(np.full((1, 2), 1e-3)))
    after = before.apply_update(states, np.array([0]), np.array([1e300]),
                                UpdateConfig(max_step_fraction=0.0, baseline="none"))
    assert after is before


def test_gradient_equals_finite_difference_of_log_prob():
    rng = np.random.default_rng(3)
    k, dim = 3, 4
    dist = InitialStateDistribution(evenly_spaced_phases(k), rng.normal(size=(k, dim)), rng.normal(scale=0.3, size=(k, dim)))
    state, component, ret = rng.normal(size=(1, dim)), np.array([1]), np.array([1.7])
    grad = dist.gradient(state, component, ret, "none")
    eps = 1e-6
    for name in ("means", "log_stds"):
        numeric = np.zeros((k, dim))
        for i in range(k):
            for d in range(dim):
                plus, minus = dist.means.copy(), dist.means.copy()
                lp, lm = dist.log_stds.copy(), dist.log_stds.copy()
                (plus if name == "means" else lp)[i, d] += eps
                (minus if name == "means" else lm)[i, d] -= eps
                up = InitialStateDistribution(dist.phases, plus, lp).log_prob(state, component)[0]
                down = InitialStateDistribution(dist.phases, minus, lm).log_prob(state, component)[0]
                numeric[i, d] = (up - down) / (2 * eps) * ret[0]
        np.testing.assert_allclose(getattr(grad, name), numeric, rtol=1e-6, atol=1e-8)


def test_log_prob_is_the_normalised_mixture_density():
    dist = hand_case()
    # N((1,2) | (0,0), diag(1, 4)) * 1/2 by hand
    expected = np.log(0.5) - np.log(2 * np.pi * 1 * 2) - 0.5 * (1 + 1)
    assert dist.log_prob(STATES[:1], COMPONENTS[:1])[0] == pytest.approx(expected, abs=1e-12)


def test_sample_statistics_match_parameters():
    rng = np.random.default_rng(7)
    k, dim, n = 3, 4, 120_000
    means = rng.normal(size=(k, dim)) * 3
    stds = rng.uniform(0.1, 2.0, size=(k, dim))
    dist = InitialStateDistribution(evenly_spaced_phases(k), means, np.log(stds))
    states, components = dist.sample(np.random.default_rng(11), n)
    assert states.dtype == np.float32 and states.shape == (n, dim)
    counts = np.bincount(components, minlength=k)
    assert np.all(np.abs(counts - n / k) < 5 * np.sqrt(n / k))  # uniform over components
    for c in range(k):
        rows = states[components == c].astype(np.float64)
        standard_error = stds[c] / np.sqrt(len(rows))
        assert np.all(np.abs(rows.mean(axis=0) - means[c]) < 5 * standard_error)
        np.testing.assert_allclose(rows.std(axis=0), stds[c], rtol=0.03)


def test_from_reference_uses_nearest_frame_and_sample_std():
    rng = np.random.default_rng(0)
    reference = rng.normal(size=(21, 5))
    reference[:, 2] = 4.0  # a constant dimension gets the floor
    ref_phases = np.linspace(0, 1, 21)
    dist = InitialStateDistribution.from_reference(reference, ref_phases, num_components=4, min_std=0.01)
    np.testing.assert_array_equal(dist.phases, [0, 0.25, 0.5, 0.75])
    np.testing.assert_array_equal(dist.means, reference[[0, 5, 10, 15]])
    expected_std = reference.std(axis=0, ddof=1)
    expected_std[2] = 0.01
    np.testing.assert_allclose(dist.stds, np.broadcast_to(expected_std, (4, 5)), rtol=1e-12)


def test_nearest_frames_picks_closest_phase():
    np.testing.assert_array_equal(nearest_frames(np.array([0.0, 0.3, 0.35, 1.0]), np.array([0.0, 0.33, 0.9])), [0, 2, 3])


def test_component_baseline_is_per_component_mean():
    returns = np.array([1.0, 3.0, 10.0, 5.0])
    components = np.array([0, 0, 2, 0])
    np.testing.assert_allclose(component_baseline(returns, components, 3, "component_mean"), [3, 3, 10, 3])
    np.testing.assert_array_equal(component_baseline(returns, components, 3, "none"), 0)
    with pytest.raises(ValueError):
        component_baseline(returns, components, 3, "global")


def test_natural_step_is_scale_free_and_matches_hand_computation():
    # component mean baseline: advantages (+1, -1, 0), std over the batch sqrt(2/3) -> A = (1, -1, 0) / sqrt(2/3)
    # component 0 (n = 2): mean z*A = ((1, 1) - (-1, 0)) / 2 / sqrt(2/3) = (1, .5) / sqrt(2/3); times sigma (1, 2)
    #   mean (z^2 - 1) A / 2 = ((0, 0) - (0, -1)) / 2 / 2 / sqrt(2/3) = (0, .25) / sqrt(2/3)
    # component 1: A = 0 -> no step
    step = hand_case().natural_step(STATES, COMPONENTS, RETURNS, "component_mean")
    a = 1 / np.sqrt(2 / 3)
    np.testing.assert_allclose(step.means, [[a, a], [0, 0]], atol=1e-12)
    np.testing.assert_allclose(step.log_stds, [[0, 0.25 * a], [0, 0]], atol=1e-12)
    # Returns scaled by 1000 and shifted: the same step (the paper's would be 1000x larger).
    same = hand_case().natural_step(STATES, COMPONENTS, 1000 * RETURNS + 7, "component_mean")
    np.testing.assert_allclose(same.means, step.means, atol=1e-9)
    flat = hand_case().natural_step(STATES, COMPONENTS, np.full(3, 2.0), "component_mean")
    assert not flat.means.any() and not flat.log_stds.any()  # no information, no step
    moved = hand_case().apply_update(STATES, COMPONENTS, RETURNS, UpdateConfig(step_size=0.1, max_step_fraction=0.0, rule="natural"))
    np.testing.assert_allclose(moved.means - MEANS, 0.1 * step.means, atol=1e-12)


def test_per_component_gradient_divides_each_component_by_k_times_its_count():
    # Sums over the hand case's episodes: row 0 (2 episodes) d mu (2, 1/2), d log sigma (0, 1); row 1 zero.
    grad = hand_case().gradient(STATES, COMPONENTS, RETURNS, "component_mean", per_component=True)
    np.testing.assert_allclose(grad.means, [[2 / 4, 0.5 / 4], [0, 0]], atol=1e-15)
    np.testing.assert_allclose(grad.log_stds, [[0, 1 / 4], [0, 0]], atol=1e-15)


def test_beta_zero_keeps_the_papers_mean_over_all_episodes():
    config = UpdateConfig(step_size=0.1, max_step_fraction=0.0)
    after = hand_case().apply_update(STATES, COMPONENTS, RETURNS, config)
    grad = hand_case().gradient(STATES, COMPONENTS, RETURNS)
    np.testing.assert_array_equal(after.means, MEANS + 0.1 * grad.means)


def test_weighted_sampling_still_steps_each_component_toward_higher_return_at_the_uniform_rate():
    """Known answer: D = 1, k = 2, sigma = 1; component 0's return is 2 s, component 1's is -s.
    With R - b = a sigma (z - zbar), E[z / sigma (R - b)] = a, so the paper's uniform draw
    (n_c = N/2) steps mu_c by alpha a / k: +1 alpha for component 0, -0.5 alpha for component 1.
    Here component 0 gets only 10 % of the episodes (failure-weighted draws went elsewhere):
    the importance-weighted step keeps +1 and -0.5 (standard errors .03 and .01; tolerance
    5 of them), where the unweighted (1/N) mean would step component 0 by only .1 x 2 = .2."""
    rng = np.random.default_rng(11)
    dist = InitialStateDistribution(np.array([0.0, 0.5]), np.array([[0.0], [5.0]]), np.zeros((2, 1)))
    components = (rng.random(20000) >= 0.1).astype(np.int64)
    states = dist.means[components] + rng.standard_normal((20000, 1))
    returns = np.where(components == 0, 2.0 * states[:, 0], -states[:, 0])
    config = UpdateConfig(step_size=0.1, max_step_fraction=0.0, fall_weighting=0.5)
    after = dist.apply_update(states, components, returns, config)
    step = (after.means - dist.means)[:, 0] / config.step_size
    assert abs(step[0] - 1.0) < 0.15 and abs(step[1] + 0.5) < 0.05
    unweighted = dist.gradient(states, components, returns).means[:, 0]
    assert abs(unweighted[0] - 0.2) < 0.05  # what the weighting corrects
