"""The globally consistent scene: e* = argmax_e sum_n f_n(e), f_n(e) = V_n(s(t_{n-1}), e) - V_n(s(t_n), e)
(002 §5.3, eq. 14-15), by SLSQP (scipy) within the boxes' domains.

V_n is window n's value network (`value.py`); s(t_{n-1}) and s(t_n) are the observations its
rollouts recorded at the window's first frame and at its control end (`handover.py`), with
their scene entries (the observation's last entries, `scene_contract`) replaced by e. Each
f_n is the mean over that window's rollouts. The last window's t_N is the clip's end, where
the episode ends: nothing is left to earn there, so V_N(s(t_N), e) is 0 by definition (the
network's output at an episode's last state is an untrained extrapolation, and where the
rollouts fell short of the end it would be the value of the state before a fall), and f_N is
V_N(s(t_{N-1}), e) alone. The objective's gradient comes from torch
autograd, exact where the observation normaliser does not clip.

Deviation: SLSQP is a local method; it starts from the user's scene (the paper's "rough
initial guess") and, because value landscapes of small networks have plateaus, from a few
more starting points spread over the domain box (`starts`); the best finite optimum wins.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import torch
from scipy.optimize import minimize

from learner.errors import SfvError


@dataclass
class WindowTerms:
    """One window's part of eq. 14: its value function and the observations it is scored at."""

    value: object  # has torch_values(obs (n, obs_dim) tensor) -> (n,) tensor
    start_obs: np.ndarray  # (n, obs_dim): s(t_{n-1})
    end_obs: np.ndarray | None  # (n, obs_dim): s(t_n); None where t_n is the clip's end (V = 0 there)


@dataclass(frozen=True)
class SceneObs:
    """Where e sits in an observation: its last `len(offset)` entries, as (e - offset) / scale."""

    offset: np.ndarray
    scale: np.ndarray

    @property
    def dim(self) -> int:
        return len(self.offset)

    def entries(self, e):
        """The observation entries of scene vector e (numpy or torch)."""
        if isinstance(e, torch.Tensor):
            return (e - torch.as_tensor(self.offset, dtype=e.dtype)) / torch.as_tensor(self.scale, dtype=e.dtype)
        return (np.asarray(e, np.float64) - self.offset) / self.scale

    def put(self, obs, e):
        """Copies of observations `obs` (n, obs_dim) with the scene entries of e."""
        if isinstance(obs, torch.Tensor):
            entries = self.entries(e).to(obs.dtype).expand(obs.shape[0], self.dim)
            return torch.cat([obs[:, : obs.shape[1] - self.dim], entries], dim=1)
        out = np.array(obs, dtype=np.float32, copy=True)
        out[:, out.shape[1] - self.dim:] = self.entries(e)
        return out


@dataclass
class FitResult:
    scene: np.ndarray  # e*
    objective: float  # sum_n f_n(e*)
    initial_objective: float  # sum_n f_n(e0), the user's scene
    window_terms: list[float]  # f_n(e*)
    success: bool
    message: str
    evaluations: int
    starts: list[dict] = field(default_factory=list)  # every SLSQP start: where from, where to, objective

    def to_dict(self) -> dict:
        return {"scene": self.scene.tolist(), "objective": self.objective, "initial_objective": self.initial_objective,
                "window_terms": self.window_terms, "success": self.success, "message": self.message,
                "evaluations": self.evaluations, "starts": self.starts}


def objective_terms(windows: list[WindowTerms], layout: SceneObs, e: torch.Tensor) -> torch.Tensor:
    """(N,) f_n(e) for a scene vector tensor e (autograd flows to it)."""
    terms = []
    for w in windows:
        start = layout.put(torch.as_tensor(w.start_obs, dtype=torch.float32), e)
        term = w.value.torch_values(start).mean()
        if w.end_obs is not None:
            term = term - w.value.torch_values(layout.put(torch.as_tensor(w.end_obs, dtype=torch.float32), e)).mean()
        terms.append(term)
    return torch.stack(terms)


def _negated(windows, layout, counter):
    """-sum_n f_n(e) and its gradient, for scipy's minimiser."""
    def fun(x):
        counter[0] += 1
        e = torch.tensor(x, dtype=torch.float64, requires_grad=True)
        total = objective_terms(windows, layout, e).sum()
        total.backward()
        return -float(total.detach()), -e.grad.numpy().astype(np.float64)
    return fun


def fit_scene(windows: list[WindowTerms], layout: SceneObs, initial: np.ndarray, bounds: np.ndarray,
              starts: int = 4, seed: int = 0, max_iterations: int = 100) -> FitResult:
    """SLSQP on -sum_n f_n(e) within `bounds` (D, 2), from `initial` and `starts - 1` random points."""
    initial = np.asarray(initial, np.float64)
    bounds = np.asarray(bounds, np.float64).reshape(-1, 2)
    if initial.shape != (layout.dim,) or bounds.shape != (layout.dim, 2):
        raise SfvError(f"scene fit: scene vector of {initial.shape} and bounds of {bounds.shape} for {layout.dim} scene entries")
    if not windows:
        raise SfvError("scene fit: no window to fit the scene with")
    if np.any(initial < bounds[:, 0] - 1e-9) or np.any(initial > bounds[:, 1] + 1e-9):
        raise SfvError(f"scene fit: the initial scene {initial.tolist()} lies outside its domain {bounds.tolist()}")
    counter = [0]
    fun = _negated(windows, layout, counter)
    rng = np.random.default_rng(seed)
    points = [initial] + [rng.uniform(bounds[:, 0], bounds[:, 1]) for _ in range(max(0, starts - 1))]
    best, records = None, []
    for x0 in points:
        res = minimize(fun, x0, jac=True, method="SLSQP", bounds=[tuple(b) for b in bounds],
                       options={"maxiter": max_iterations, "ftol": 1e-9})
        x = np.clip(res.x, bounds[:, 0], bounds[:, 1])  # SLSQP may overstep a bound by rounding
        value = -fun(x)[0]
        records.append({"from": x0.tolist(), "to": x.tolist(), "objective": value, "success": bool(res.success)})
        if np.isfinite(value) and (best is None or value > best[1]):
            best = (x, value, res)
    if best is None:
        raise SfvError("scene fit: the objective was not finite at any SLSQP optimum")
    x, value, res = best
    with torch.no_grad():
        terms = objective_terms(windows, layout, torch.tensor(x, dtype=torch.float64)).tolist()
    return FitResult(x, float(value), float(-fun(initial)[0]), [float(t) for t in terms], bool(res.success),
                     str(res.message), counter[0], records)
