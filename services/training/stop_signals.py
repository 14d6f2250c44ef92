"""Stop training at an iteration's end on SIGTERM or SIGINT, checkpoint first (`Trainer`).

A cluster scheduler (Kubernetes, KubeRay, Slurm) preempts with SIGTERM and kills a while later; a
person presses Ctrl-C. Without this, a stop lost up to `checkpoint_every` iterations (10: about
40 k samples, 15-20 s on two cores) and left metrics rows past the newest checkpoint. With it, the
first signal lets the current iteration finish (one collect and update: about 1 s on two cores),
writes a checkpoint and raises `TrainingStopped`; a second signal acts at once, as it would
without this. Installed only from the main thread (Python delivers signals there alone).
"""
from __future__ import annotations

import os
import signal
import threading

STOP_SIGNALS = (signal.SIGTERM, signal.SIGINT)


class StopSignals:
    """Context manager: `requested` is the first stop signal's number (None before any)."""

    def __init__(self):
        self.requested: int | None = None
        self._previous: dict[int, object] = {}

    def __enter__(self) -> "StopSignals":
        if threading.current_thread() is threading.main_thread():
            for number in STOP_SIGNALS:
                self._previous[number] = signal.signal(number, self._handle)
        return self

    def __exit__(self, *exc) -> None:
        self._restore()

    @property
    def name(self) -> str:
        return signal.Signals(self.requested).name if self.requested is not None else ""

    def _handle(self, number: int, frame) -> None:
        if self.requested is None:
            self.requested = number
            return
        self._restore()  # a second signal: what it would have done without us
        if number == signal.SIGINT:
            raise KeyboardInterrupt
        os.kill(os.getpid(), number)

    def _restore(self) -> None:
        for number, previous in self._previous.items():
            signal.signal(number, previous if previous is not None else signal.SIG_DFL)
        self._previous.clear()
