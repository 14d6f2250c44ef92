"""Training without Ray: `RolloutWorker`s in plain processes under the real training loop.

`MultiprocessTrainer` is `services.trainer.Trainer` with only the transport swapped: each
worker lives in its own spawned process and talks over a pipe instead of being a Ray actor
(for machines without Ray, e.g. a GPU box, and for `bench/scaling.py`). Worker processes get
one BLAS/OpenMP thread each, as Ray gives its 1-CPU actors. A worker that fails stops the
run with its error (no restarts: this is a measurement tool, not the fault-tolerant path).
"""
from __future__ import annotations

import contextlib
import multiprocessing as mp
import os

from services.bench.env_suite import env_config_for
from services.bench.measure import rate_for
from services.bench.steppers import RawPhysics
from services.train_config import TrainConfig
from services.trainer import Trainer

SINGLE_THREAD_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


@contextlib.contextmanager
def child_environment(values: dict[str, str]):
    """Environment variables that spawned children inherit; this process's own are restored."""
    saved = {k: os.environ.get(k) for k in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


def _serve_worker(spec, index: int, conn) -> None:
    from actors.rollout_worker import RolloutWorker

    try:
        worker = RolloutWorker(spec, index)
        conn.send(("ready", index))
        while (request := conn.recv()) is not None:
            conn.send(("batch", worker.sample(*request)))
    except Exception as exc:  # reported to the driver, which stops the run
        conn.send(("error", f"worker {index}: {type(exc).__name__}: {exc}"))


class ProcessWorker:
    def __init__(self, context, spec, index: int):
        self.conn, child = context.Pipe()
        self.proc = context.Process(target=_serve_worker, args=(spec, index, child), daemon=True)
        self.proc.start()
        child.close()
        self.index = index

    def receive(self):
        kind, payload = self.conn.recv()
        if kind == "error":
            raise RuntimeError(payload)
        return payload

    def close(self) -> None:
        with contextlib.suppress(OSError):
            self.conn.send(None)
        self.proc.join(timeout=10)
        if self.proc.is_alive():
            self.proc.kill()
            self.proc.join()


class MultiprocessTrainer(Trainer):
    """The training driver with its workers in plain processes instead of Ray actors."""

    def __init__(self, config: TrainConfig):
        super().__init__(config, progress=False)
        self.context = mp.get_context("spawn")
        self.processes: list[ProcessWorker] = []

    def _init_ray(self):
        pass

    def _make_workers(self, spec):
        with child_environment(SINGLE_THREAD_ENV):
            self.processes = [ProcessWorker(self.context, spec, i) for i in range(self.config.workers)]
        for worker in self.processes:
            worker.receive()  # construction errors surface here, before the timed loop
        return self.processes

    def _collect(self, workers, weights, version: int, steps: int) -> list[dict]:
        for worker in workers:
            worker.conn.send((weights, version, steps))
        return [worker.receive() for worker in workers]

    def close(self) -> None:
        for worker in self.processes:
            worker.close()


# ------------------------------------------------------------ raw bound, N at once
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
