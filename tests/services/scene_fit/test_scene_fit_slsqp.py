"""The scene fit's SLSQP (002 eq. 14-15) on value functions whose optimum is known."""
from __future__ import annotations

import numpy as np
import torch

from services.scene_fit.fit import SceneObs, WindowTerms, fit_scene, objective_terms

OBS_DIM = 6


class QuadraticValue:
    """V(o) = o[0] * (1 - |o_scene - target|^2): f_n = V(start, e) - V(end, e) with o[0] = 1 at
    the start and 0 at the end is 1 - |entries(e) - target|^2, best at entries(e) = target."""

    def __init__(self, target):
        self.target = torch.as_tensor(target, dtype=torch.float32)

    def torch_values(self, obs: torch.Tensor) -> torch.Tensor:
        scene = obs[:, OBS_DIM - len(self.target):]
        return obs[:, 0] * (1.0 - ((scene - self.target) ** 2).sum(dim=1))


def _terms(value, rows=3, seed=0):
    rng = np.random.default_rng(seed)
    start, end = rng.normal(size=(rows, OBS_DIM)).astype(np.float32), rng.normal(size=(rows, OBS_DIM)).astype(np.float32)
    start[:, 0], end[:, 0] = 1.0, 0.0
    return WindowTerms(value, start, end)


LAYOUT = SceneObs(offset=np.array([1.0, 0.3]), scale=np.array([0.3, 0.3]))  # along 1 m, height 0.3 m, +-0.3 m
BOUNDS = np.array([[0.7, 1.3], [0.0, 0.6]])


def test_slsqp_finds_an_interior_optimum():
    truth = np.array([1.12, 0.41])
    result = fit_scene([_terms(QuadraticValue(LAYOUT.entries(truth)))], LAYOUT, np.array([1.0, 0.3]), BOUNDS)
    np.testing.assert_allclose(result.scene, truth, atol=1e-4)
    assert result.objective > result.initial_objective
    assert abs(result.objective - 1.0) < 1e-6


def test_slsqp_stops_at_the_domain_when_the_optimum_lies_beyond():
    beyond = np.array([1.6, -0.2])  # both outside the domain
    result = fit_scene([_terms(QuadraticValue(LAYOUT.entries(beyond)))], LAYOUT, np.array([1.0, 0.3]), BOUNDS)
    np.testing.assert_allclose(result.scene, [1.3, 0.0], atol=1e-6)
    assert np.all(result.scene >= BOUNDS[:, 0]) and np.all(result.scene <= BOUNDS[:, 1])


def test_windows_sum_their_terms():
    a, b = np.array([0.8, 0.2]), np.array([1.2, 0.4])  # two windows disagree: the sum is best halfway
    windows = [_terms(QuadraticValue(LAYOUT.entries(a)), seed=1), _terms(QuadraticValue(LAYOUT.entries(b)), seed=2)]
    result = fit_scene(windows, LAYOUT, np.array([0.75, 0.5]), BOUNDS)
    np.testing.assert_allclose(result.scene, (a + b) / 2, atol=1e-4)
    assert len(result.window_terms) == 2 and abs(sum(result.window_terms) - result.objective) < 1e-6


def test_scene_entries_replace_only_the_last_observation_entries():
    obs = np.arange(12, dtype=np.float32).reshape(2, OBS_DIM)
    e = np.array([1.15, 0.0])
    put = LAYOUT.put(obs, e)
    np.testing.assert_array_equal(put[:, :4], obs[:, :4])
    np.testing.assert_allclose(put[:, 4:], [[0.5, -1.0], [0.5, -1.0]])
    assert obs[0, 4] == 4  # the caller's rows are left as they were
    torch_put = LAYOUT.put(torch.as_tensor(obs), torch.tensor(e))
    np.testing.assert_allclose(torch_put.numpy(), put, rtol=1e-6)


def test_objective_gradient_matches_finite_differences():
    windows = [_terms(QuadraticValue([0.2, -0.4]))]
    e = torch.tensor([0.9, 0.35], dtype=torch.float64, requires_grad=True)
    objective_terms(windows, LAYOUT, e).sum().backward()
    h, numeric = 1e-4, []
    for i in range(2):
        step = np.zeros(2)
        step[i] = h
        plus = objective_terms(windows, LAYOUT, torch.tensor(e.detach().numpy() + step)).sum()
        minus = objective_terms(windows, LAYOUT, torch.tensor(e.detach().numpy() - step)).sum()
        numeric.append(float(plus - minus) / (2 * h))
    np.testing.assert_allclose(e.grad.numpy(), numeric, rtol=1e-3)


def test_a_window_ending_with_the_clip_scores_its_start_alone():
    """The clip's end is an episode's end: V there is 0 by definition, so the end observations
    (here ones whose V would pull the optimum elsewhere) do not count."""
    class StartOnly(QuadraticValue):
        def torch_values(self, obs):
            scene = obs[:, OBS_DIM - len(self.target):]
            return (1.0 - ((scene - self.target) ** 2).sum(dim=1)) * (obs[:, 0] > 0.5) + 5.0 * scene[:, 0] * (obs[:, 0] <= 0.5)

    truth = np.array([1.05, 0.2])
    terms = _terms(StartOnly(LAYOUT.entries(truth)))
    terms.end_obs = None
    result = fit_scene([terms], LAYOUT, np.array([1.0, 0.3]), BOUNDS)
    np.testing.assert_allclose(result.scene, truth, atol=1e-4)
    with_end = fit_scene([_terms(StartOnly(LAYOUT.entries(truth)))], LAYOUT, np.array([1.0, 0.3]), BOUNDS)
    assert with_end.scene[0] < 0.75  # the end's term (falling in along) drags it to the lower bound
