"""The ASI initial-state distribution: k diagonal Gaussians at fixed phases (pure numpy).

rho_omega(s) = p(phi) * N(s | mu_c, diag(sigma_c^2)), with p(phi) uniform over the k
fixed phases phi_c (SFV §9). The parameters omega are the means mu (k, D) and the
log standard deviations log_sigma (k, D); log-std keeps sigma positive under a
gradient step.

Gradient of the log-density of one state s drawn from component c (z = (s - mu_c) / sigma_c):
    d log rho / d mu_c        = (s - mu_c) / sigma_c^2 = z / sigma_c
    d log rho / d log sigma_c = (s - mu_c)^2 / sigma_c^2 - 1 = z^2 - 1
(log N = -sum_d [log sigma_d + (s_d - mu_d)^2 / (2 sigma_d^2)] + const; differentiate
in mu_d, and in log sigma_d using d sigma_d^-2 / d log sigma_d = -2 sigma_d^-2.)
The derivatives with respect to any other component are zero.

One update (Supplementary A, one step per batch of N episodes):
    omega += alpha * (1/N) * sum_e grad_omega log rho(s0_e) * (R0_e - b_{c_e})
The mean is over ALL N episodes of the batch, so each component's step is its own
episodes' sum divided by N -- the unbiased estimate of grad J. The baseline b_c is
the batch's mean return of the episodes from component c (a per-phase control
variate: returns differ strongly along the motion, so a single global baseline
would push every component toward or away from the phases that are easy anyway);
Baseline "none" uses b = 0 as in Algorithm 1.

Under failure-weighted sampling (fall_weighting beta > 0, services/asi/fall_weights.py) the
components are drawn with q_c != 1/k, and that mean no longer estimates grad J: its
component-c part sums n_c ~ q_c N episodes, so it estimates sum_c q_c grad_c E_c[R], each
component's step scaled by k q_c -- the often-failing phases would also move k q_c times
faster, and a phase drawn at the floor (1 - beta)/k would all but freeze. The per-component
baseline does not mend this: it keeps each component's direction unbiased
(E_c[grad log N_c] = 0 for any q), not its scale. So with beta > 0 each component's sum is
importance-weighted back to the paper's p(phi) = 1/k, with the weight its batch share gives:
    grad = sum_c (1/k) (1/n_c) sum_{e in c} grad log rho(s_e) (R_e - b_c)
(self-normalised per component, so it needs no record of the q each episode was drawn
with, which changes as the fall rates do; unbiased given n_c > 0, and the beta < 1 floor
makes n_c = 0 vanishingly rare at 2000 episodes). beta = 0 keeps the (1/N) form bit for bit.
The natural rule already averages within each component, so it is unaffected by q.

Safeguards (switchable, documented in services/asi/README.md):
- max_step_fraction f > 0 clips every coordinate of the mean step to |d mu| <= f * sigma
  and of the log-std step to |d log sigma| <= f (sigma changes by at most a factor e^f).
  With a small sigma the raw mean step alpha * z / sigma * (R - b) can jump many
  sigmas in one update; f = 0 applies the raw step.
- sigma is floored at min_std so a collapsing component can still explore.
- a step that would produce a non-finite parameter is rejected (the batch is consumed).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

BASELINES = ("component_mean", "none")
UPDATE_RULES = ("gradient", "natural")


@dataclass(frozen=True)
class UpdateConfig:
    step_size: float = field(default=1e-3, metadata={"help": "alpha_rho, the ASI step size (paper: 0.001)"})
    episodes_per_update: int = field(default=2000, metadata={"help": "episodes per gradient step (paper: 2000)"})
    max_step_fraction: float = field(
        default=0.5, metadata={"help": "clip |d mu| to this fraction of sigma and |d log sigma| to it; 0 = raw step"})
    min_std: float = field(default=1e-3, metadata={"help": "floor on every standard deviation"})
    baseline: str = field(default="component_mean", metadata={"help": "'component_mean' or 'none'"})
    rule: str = field(default="gradient", metadata={"help": "'gradient': the paper's step (alpha 0.001); 'natural': advantages normalised over the batch and the Fisher-preconditioned step per component, so alpha is the step in units of sigma (e.g. 0.1; see natural_step)"})
    fall_weighting: float = field(default=0.0, metadata={"help": "beta in [0, 1]: components drawn with p_c = (1 - beta)/k + beta f_c / sum f, f_c the running fall rate of component c's episodes; 0 = the paper's uniform p(phi) (services/asi/fall_weights.py)"})


@dataclass(frozen=True)
class Gradient:
    means: np.ndarray      # (k, D) d J / d mu
    log_stds: np.ndarray   # (k, D) d J / d log sigma


class InitialStateDistribution:
    """k diagonal Gaussians over a D-dimensional state, one per fixed phase."""

    def __init__(self, phases: np.ndarray, means: np.ndarray, log_stds: np.ndarray):
        self.phases = np.asarray(phases, dtype=np.float64).reshape(-1)
        self.means = np.asarray(means, dtype=np.float64)
        self.log_stds = np.asarray(log_stds, dtype=np.float64)
        k = self.phases.shape[0]
        if self.means.ndim != 2 or self.means.shape[0] != k or self.log_stds.shape != self.means.shape:
            raise ValueError(f"means {self.means.shape} and log_stds {self.log_stds.shape} must both be ({k}, D)")

    @property
    def num_components(self) -> int:
        return self.means.shape[0]

    @property
    def state_dim(self) -> int:
        return self.means.shape[1]

    @property
    def stds(self) -> np.ndarray:
        return np.exp(self.log_stds)

    @classmethod
    def from_reference(cls, reference_states: np.ndarray, reference_phases: np.ndarray,
                       num_components: int = 10, phases: np.ndarray | None = None,
                       min_std: float = 1e-3) -> "InitialStateDistribution":
        """Paper's initialisation: mean = reference state at phi_i, std = per-dim sample std.

        The state is opaque (it may hold quaternions), so the reference state "at phi_i"
        is the frame whose phase is nearest, not an interpolation.
        """
        reference_states = np.asarray(reference_states, dtype=np.float64)
        phases = evenly_spaced_phases(num_components) if phases is None else np.asarray(phases, np.float64)
        means = reference_states[nearest_frames(np.asarray(reference_phases, np.float64), phases)]
        stds = np.broadcast_to(reference_std(reference_states, min_std), means.shape)
        return cls(phases, means, np.log(stds))

    def sample(self, rng: np.random.Generator, count: int,
               weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Draw `count` states: a component (uniform over k, or with probabilities `weights`),
        then the component's Gaussian.

        Returns (states (count, D) float32, components (count,) int32).
        """
        if weights is None:
            components = rng.integers(self.num_components, size=count).astype(np.int32)
        else:
            components = rng.choice(self.num_components, size=count, p=weights).astype(np.int32)
        # Drawn and shifted in float32, the output dtype: no float64 copy of a (count, D) batch.
        states = rng.standard_normal((count, self.state_dim), dtype=np.float32)
        states *= self.stds.astype(np.float32)[components]
        states += self.means.astype(np.float32)[components]
        return states, components

    def log_prob(self, states: np.ndarray, components: np.ndarray) -> np.ndarray:
        """log rho(s) = log(1/k) + log N(s | mu_c, sigma_c^2), per row."""
        states = np.asarray(states, dtype=np.float64)
        mu, log_sigma = self.means[components], self.log_stds[components]
        z = (states - mu) * np.exp(-log_sigma)
        log_normal = -0.5 * np.sum(z * z, axis=1) - np.sum(log_sigma, axis=1) - 0.5 * self.state_dim * np.log(2 * np.pi)
        return log_normal - np.log(self.num_components)

    def gradient(self, states: np.ndarray, components: np.ndarray, returns: np.ndarray,
                 baseline: str = "component_mean", per_component: bool = False) -> Gradient:
        """(1/N) sum_e grad log rho(s_e) * (R_e - b_{c_e}) for means and log-stds; with
        `per_component` each component's sum over (k n_c) instead (non-uniform draws, see above)."""
        states = np.asarray(states, dtype=np.float64)
        components = np.asarray(components, dtype=np.intp)
        returns = np.asarray(returns, dtype=np.float64)
        n = states.shape[0]
        advantages = returns - component_baseline(returns, components, self.num_components, baseline)
        inv_sigma = np.exp(-self.log_stds)[components]
        z = (states - self.means[components]) * inv_sigma
        weighted_z = z * advantages[:, None]
        # Scatter-add each episode's term onto its own component's row.
        grad_means = np.zeros_like(self.means)
        grad_log_stds = np.zeros_like(self.log_stds)
        np.add.at(grad_means, components, weighted_z * inv_sigma)
        np.add.at(grad_log_stds, components, weighted_z * z - advantages[:, None])
        if per_component:
            n = self.num_components * np.maximum(np.bincount(components, minlength=self.num_components), 1)[:, None]
        return Gradient(grad_means / n, grad_log_stds / n)

    def natural_step(self, states: np.ndarray, components: np.ndarray, returns: np.ndarray,
                     baseline: str = "component_mean") -> Gradient:
        """The natural-gradient direction, scale-free (the `rule="natural"` update).

        The paper's step alpha * (1/N) sum z/sigma (R - b) grows as 1/sigma and with the
        return's scale: at alpha 0.001 it moved the walk's Gaussians by well under 1 % of
        sigma per update, so ASI acted as a perturbed reference start. Here the advantages
        A = (R - b) / std(R - b) are normalised over the batch, and each component's
        gradient is preconditioned by the Gaussian's Fisher information (1/sigma^2 for mu,
        2 for log sigma) and averaged over that component's own episodes:
            d mu_c        = sigma_c * mean_{e in c}(z_e A_e)
            d log sigma_c = mean_{e in c}((z_e^2 - 1) A_e) / 2
        so alpha is the step in units of sigma (d mu_c = alpha sigma_c corr(z, A))."""
        states = np.asarray(states, dtype=np.float64)
        components = np.asarray(components, dtype=np.intp)
        advantages = np.asarray(returns, dtype=np.float64) - component_baseline(np.asarray(returns, np.float64), components,
                                                                                self.num_components, baseline)
        scale = advantages.std()
        if not scale > 0:
            return Gradient(np.zeros_like(self.means), np.zeros_like(self.log_stds))
        advantages = advantages / scale
        sigma = np.exp(self.log_stds)
        z = (states - self.means[components]) / sigma[components]
        sums_mu = np.zeros_like(self.means)
        sums_sigma = np.zeros_like(self.log_stds)
        np.add.at(sums_mu, components, z * advantages[:, None])
        np.add.at(sums_sigma, components, (z * z - 1.0) * advantages[:, None])
        counts = np.maximum(np.bincount(components, minlength=self.num_components), 1)[:, None]
        return Gradient(sigma * sums_mu / counts, 0.5 * sums_sigma / counts)

    def apply_update(self, states: np.ndarray, components: np.ndarray, returns: np.ndarray,
                     config: UpdateConfig) -> "InitialStateDistribution":
        """One policy-gradient ascent step on (mu, log sigma); returns the new distribution.

        Returns `self` unchanged if the step would produce a non-finite parameter.
        """
        with np.errstate(over="ignore", invalid="ignore"):  # overflow is caught by the finiteness check below
            if config.rule == "natural":
                step = self.natural_step(states, components, returns, config.baseline)
            else:
                step = self.gradient(states, components, returns, config.baseline, per_component=config.fall_weighting > 0)
            step_means = config.step_size * step.means
            step_log_stds = config.step_size * step.log_stds
        if config.max_step_fraction > 0:
            limit = config.max_step_fraction * self.stds
            step_means = np.clip(step_means, -limit, limit)
            step_log_stds = np.clip(step_log_stds, -config.max_step_fraction, config.max_step_fraction)
        means = self.means + step_means
        log_stds = np.maximum(self.log_stds + step_log_stds, np.log(config.min_std))
        if not (np.all(np.isfinite(means)) and np.all(np.isfinite(log_stds))):
            return self
        return InitialStateDistribution(self.phases, means, log_stds)


def evenly_spaced_phases(num_components: int) -> np.ndarray:
    """phi_i = i / k, i = 0 .. k-1."""
    return np.arange(num_components, dtype=np.float64) / num_components


def nearest_frames(reference_phases: np.ndarray, phases: np.ndarray) -> np.ndarray:
    """Index of the reference frame whose phase is closest to each phase (ties -> earlier frame)."""
    return np.argmin(np.abs(reference_phases[None, :] - phases[:, None]), axis=1)


def reference_std(reference_states: np.ndarray, min_std: float) -> np.ndarray:
    """Per-dimension sample std (ddof=1) of the clip's states, floored at min_std."""
    ddof = 1 if reference_states.shape[0] > 1 else 0
    return np.maximum(np.std(reference_states, axis=0, ddof=ddof), min_std)


def component_baseline(returns: np.ndarray, components: np.ndarray, num_components: int,
                       baseline: str) -> np.ndarray:
    """Per-episode baseline b_{c_e}: the mean return of its component in this batch (or 0)."""
    if baseline == "none":
        return np.zeros_like(returns)
    if baseline != "component_mean":
        raise ValueError(f"unknown baseline {baseline!r}; expected one of {BASELINES}")
    sums = np.bincount(components, weights=returns, minlength=num_components)
    counts = np.bincount(components, minlength=num_components)
    means = sums / np.maximum(counts, 1)
    return means[components]
