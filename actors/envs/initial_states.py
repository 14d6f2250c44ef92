"""Where episodes start: a batch of initial states, and local sources of them.

The rollout worker asks a source for `count` starts at a time. A start is a phase and,
for ASI, a full state vector (see `actors.character.state`); FSI/RSI starts carry no state: the env
puts the character on the reference at that phase. Remote sources (the ASI server) live in
`actors.rollout.asi_client`; these local ones serve tests and runs without a server.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class InitialStates:
    phases: np.ndarray  # (n,)
    components: np.ndarray  # (n,) int: ASI component, or -1
    states: np.ndarray | None = None  # (n, state_dim) or None for reference starts

    def __len__(self) -> int:
        return len(self.phases)


class ReferenceStarts:
    """FSI (phase 0) or RSI (uniform phase) without any server."""

    def __init__(self, strategy: str, rng: np.random.Generator):
        if strategy not in ("fsi", "rsi"):
            raise ValueError(f"local starts are fsi or rsi, got {strategy!r}")
        self.strategy = strategy
        self.rng = rng

    def __call__(self, count: int) -> InitialStates:
        phases = np.zeros(count) if self.strategy == "fsi" else self.rng.random(count)
        return InitialStates(phases, np.full(count, -1, dtype=np.int64))


class BufferedStarts:
    """Draws starts from a source in batches, so a remote source is asked rarely."""

    def __init__(self, source, batch: int = 64):
        self.source = source
        self.batch = batch
        self._buffer: InitialStates | None = None
        self._next = 0

    def take(self):
        """One start: (phase, component, state or None)."""
        if self._buffer is None or self._next >= len(self._buffer):
            self._buffer, self._next = self.source(self.batch), 0
        i, b = self._next, self._buffer
        self._next += 1
        return float(b.phases[i]), int(b.components[i]), None if b.states is None else b.states[i]


class FirstFrameStarts:
    """`take()` like `BufferedStarts`: with probability `share` the reference's first frame
    (phase 0, component -1: never reported to ASI), else the wrapped source's start.

    Why, for a clip that does not loop: uniform phases (RSI, ASI's components) leave the clip's
    first frames the least trained, since frame t is reached only by episodes that started
    before it. On the 1.67 s Pose2Sim clip the training's samples per frame bin rose ~9x from
    the first bins to the last (30 -> 270 per iteration), yet the episode a user plays starts
    at the first frame. A share w makes frame t's visits w + (1 - w) t / T of the last's.
    """

    def __init__(self, starts, share: float, rng: np.random.Generator):
        if not 0.0 <= share <= 1.0:
            raise ValueError(f"first-frame share must lie in [0, 1], got {share}")
        self.starts, self.share, self.rng = starts, float(share), rng

    def take(self):
        if self.rng.random() < self.share:
            return self._first_frame()
        return self.starts.take()

    def _first_frame(self):
        """(phase 0, component -1, state): None puts the character on the reference there."""
        return 0.0, -1, None
