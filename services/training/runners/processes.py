"""Rollout workers in plain spawned processes that talk over pipes: training without Ray
(a GPU box without the Ray wheel, `services/bench/scripts/scaling.py`).

Worker processes get one BLAS/OpenMP thread each, as Ray gives its 1-CPU actors. A worker
that fails stops the run with its error (no restarts: the fault-tolerant path is Ray's).
"""
from __future__ import annotations

import contextlib
import multiprocessing as mp
import os
import signal

from learner.errors import SfvError
from services.training.runners.base import WorkerRunner

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


def _serve_worker(worker_class, spec, index: int, conn) -> None:
    # Ctrl-C reaches the whole process group: the driver stops the run (finishing the iteration
    # and checkpointing, `stop_signals.py`) and closes the pipe, which ends this loop.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        worker = worker_class(spec, index)
        conn.send(("ready", index))
        while (request := conn.recv()) is not None:
            weights, version, steps, options = request
            conn.send(("batch", worker.sample(weights, version, steps, **options)))
    except EOFError:  # the driver closed the pipe: the run is over (no traceback for people to read)
        return
    except Exception as exc:  # reported to the driver, which stops the run
        with contextlib.suppress(OSError):  # a driver already gone cannot hear it
            conn.send(("error", f"worker {index}: {type(exc).__name__}: {exc}"))


class ProcessWorker:
    def __init__(self, context, worker_class, spec, index: int):
        self.conn, child = context.Pipe()
        self.proc = context.Process(target=_serve_worker, args=(worker_class, spec, index, child), daemon=True)
        self.proc.start()
        child.close()
        self.index = index

    def receive(self):
        kind, payload = self.conn.recv()
        if kind == "error":
            raise SfvError(f"rollout {payload}")
        return payload

    def close(self) -> None:
        with contextlib.suppress(OSError):
            self.conn.send(None)
        self.proc.join(timeout=10)
        if self.proc.is_alive():
            self.proc.kill()
            self.proc.join()


class ProcessRunner(WorkerRunner):
    name = "processes"

    def start(self, spec) -> None:
        context = mp.get_context("spawn")
        with child_environment(SINGLE_THREAD_ENV):
            self.workers = [ProcessWorker(context, self.worker_class, spec, i) for i in range(self.config.workers)]
        for worker in self.workers:
            worker.receive()  # construction errors surface here, before the first iteration

    def _sample(self, weights, version, steps, options):
        for worker in self.workers:
            worker.conn.send((weights, version, steps, options))
        return [worker.receive() for worker in self.workers]

    def close(self) -> None:
        for worker in self.workers:
            worker.close()
