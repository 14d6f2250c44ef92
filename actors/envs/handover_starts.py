"""Episode starts handed over from the previous window's policy (002 §5.3).

"The initial state of this next window is parameterized by the policy trained for the
previous window": a window's training starts a share of its episodes at its first frame
(phase 0) from states the previous window's policy reached there (rollouts of it, see
`services/scene_fit/handover.py`), the rest from the worker's usual source (ASI, RSI or FSI),
so the policy also learns the rest of its window. Handed-over starts carry component -1:
the ASI client never reports them to the server.
"""
from __future__ import annotations

import numpy as np

from actors.envs.initial_states import FirstFrameStarts


class HandoverStarts(FirstFrameStarts):
    """`take()` like `BufferedStarts`: with probability `share` a hand-over state at phase 0."""

    def __init__(self, starts, states: np.ndarray, share: float, rng: np.random.Generator):
        states = np.asarray(states, np.float64)
        if states.ndim != 2 or len(states) == 0 or not np.isfinite(states).all():
            raise ValueError(f"hand-over states must be a non-empty (n, state_dim) finite array, got shape {states.shape}")
        if not 0.0 <= share <= 1.0:
            raise ValueError(f"hand-over share must lie in [0, 1], got {share}")
        super().__init__(starts, share, rng)
        self.states = states

    def _first_frame(self):
        return 0.0, -1, self.states[int(self.rng.integers(len(self.states)))]
