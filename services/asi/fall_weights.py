"""Failure-weighted choice of the ASI component: start more episodes where episodes fall (pure numpy).

ProtoMotions and PHC sample motions in proportion to how often they fail; here the same
lever acts within one clip, over the k phases of the ASI distribution. With beta, the job's
`fall_weighting`, SampleInitialStates(ASI) draws component c with

    p_c = (1 - beta) / k + beta * f_c / sum_j f_j        (uniform while nothing has fallen)

where f_c is the running fall rate of the episodes started from component c. beta = 0 is
the paper's uniform p(phi); the (1 - beta)/k floor keeps every phase sampled, so every
phase's fall rate and ASI gradient stay measured.

The running fall rate is an exponentially decayed ratio of counts, per component:

    falls_c    <- d^{n_c} falls_c    + (falls among this report's n_c episodes from c)
    episodes_c <- d^{n_c} episodes_c + n_c,        f_c = falls_c / episodes_c,

d = 2^(-1 / FALL_RATE_HALF_LIFE): an episode's weight halves with every FALL_RATE_HALF_LIFE
later episodes from its component. Why this estimator rather than counts over a window:
the fall rate is a property of the current policy, which keeps learning, so old episodes
must fade; an exponential decay does that in 2k numbers per job (one atomic Redis write),
where a window would keep every recent flag. Dividing by the decayed episode count (not
starting an EMA at 0) makes f_c the plain mean over a component's first episodes, so
a young job's rates are not biased toward 0; decaying per episode of the component (not per
report) gives a rarely drawn component the same effective sample, ~2 x half-life episodes.
The episodes of one report count as simultaneous, so the update is independent of their
order within the report and both stores compute it bit for bit alike.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Half-life in episodes of one component. At the defaults (k = 10, 2000 episodes per ASI
# step) a component sees ~200 episodes per step, so the rate follows the policy within about
# one ASI step; a fall rate of .2 is then known to about +-.03 (binomial over ~150 episodes).
FALL_RATE_HALF_LIFE = 100.0
FALL_DECAY = 0.5 ** (1.0 / FALL_RATE_HALF_LIFE)


@dataclass(frozen=True)
class FallStats:
    """Decayed fall and episode counts per ASI component."""

    falls: np.ndarray     # (k,) float64
    episodes: np.ndarray  # (k,) float64

    @classmethod
    def empty(cls, num_components: int) -> "FallStats":
        return cls(np.zeros(num_components), np.zeros(num_components))

    @property
    def rates(self) -> np.ndarray:
        """f_c; 0 for a component without reported episodes."""
        return np.divide(self.falls, self.episodes, out=np.zeros_like(self.falls), where=self.episodes > 0)

    def updated(self, components: np.ndarray, fell: np.ndarray) -> "FallStats":
        """The counts after one report's episodes (components (n,), fell (n,) bool)."""
        k = self.falls.shape[0]
        started = np.bincount(components, minlength=k).astype(np.float64)
        fallen = np.bincount(components, weights=np.asarray(fell, np.float64), minlength=k)
        decay = FALL_DECAY ** started
        return FallStats(self.falls * decay + fallen, self.episodes * decay + started)

    def to_bytes(self) -> bytes:
        return np.concatenate([self.falls, self.episodes]).astype("<f8").tobytes()

    @classmethod
    def from_bytes(cls, blob: bytes | None, num_components: int) -> "FallStats":
        """The stats written by to_bytes; empty for a job that has none yet (None)."""
        if blob is None:
            return cls.empty(num_components)
        values = np.frombuffer(blob, "<f8").reshape(2, num_components)
        return cls(values[0].copy(), values[1].copy())


def sampling_weights(fall_rates: np.ndarray, beta: float) -> np.ndarray | None:
    """p_c = (1 - beta)/k + beta f_c / sum f; None when the draw is the paper's uniform one
    (beta 0, or nothing has fallen), so that draw stays bit-identical to it."""
    total = float(np.sum(fall_rates))
    if beta == 0 or not total > 0:
        return None
    k = fall_rates.shape[0]
    return (1.0 - beta) / k + beta * np.asarray(fall_rates, np.float64) / total


def component_weights(fall_rates: np.ndarray, beta: float) -> np.ndarray:
    """The probability of each component in the next ASI draw (uniform included)."""
    weights = sampling_weights(fall_rates, beta)
    k = fall_rates.shape[0]
    return np.full(k, 1.0 / k) if weights is None else weights
