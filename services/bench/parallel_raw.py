"""The raw physics bound with N processes stepping at once (the denominator of the scaling
benchmark's ratios): each spawned process steps bare MuJoCo models, one BLAS thread each."""
from __future__ import annotations

import multiprocessing as mp

from services.bench.env_suite import env_config_for
from services.bench.measure import rate_for
from services.bench.steppers import RawPhysics
from services.training.runners.processes import SINGLE_THREAD_ENV, child_environment


def _raw_rate(physics_hz: float, seconds: float, barrier, results) -> None:
    raw = RawPhysics(env_config_for(physics_hz))
    raw.chunk()
    barrier.wait()
    results.put(rate_for(seconds, raw.chunk).wall)


def parallel_raw_steps_per_s(physics_hz: float, seconds: float, processes: int) -> float:
    """Sum of the raw rates of `processes` processes stepping at the same time."""
    context = mp.get_context("spawn")
    barrier, results = context.Barrier(processes), context.Queue()
    with child_environment(SINGLE_THREAD_ENV):
        procs = [context.Process(target=_raw_rate, args=(physics_hz, seconds, barrier, results)) for _ in range(processes)]
        for p in procs:
            p.start()
    rates = [results.get(timeout=120 + seconds) for _ in procs]
    for p in procs:
        p.join()
    return sum(rates)
