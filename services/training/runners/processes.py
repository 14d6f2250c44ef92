"""Rollout workers in plain spawned processes that talk over pipes: training without Ray
(a GPU box without the Ray wheel, `bench/scripts/scaling.py`).

Worker processes get one BLAS/OpenMP thread each, as Ray gives its 1-CPU actors. A worker
that raises stops the run with its error; a worker process that dies (killed, out of memory)
is started again and its share handed to it again, with a line saying so (`worker_restarts`).
"""
from __future__ import annotations

import contextlib
import multiprocessing as mp
import os
import signal
from multiprocessing.connection import wait as wait_for_pipes

from learner.errors import SfvError
from services.training.runners.base import WorkerRunner, log

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


class WorkerProcessDied(Exception):
    """A worker's process ended without a word (SIGKILL, the out-of-memory killer)."""


class ProcessWorker:
    def __init__(self, context, worker_class, spec, index: int):
        self.conn, child = context.Pipe()
        self.proc = context.Process(target=_serve_worker, args=(worker_class, spec, index, child), daemon=True)
        self.proc.start()
        child.close()
        self.index = index

    def receive(self):
        try:
            kind, payload = self.conn.recv()
        except (EOFError, ConnectionResetError) as exc:  # the process died: no error from it to report
            raise WorkerProcessDied(f"worker {self.index}: process {self.proc.pid} ended ({type(exc).__name__}, exit code "
                                    f"{self.proc.exitcode if not self.proc.is_alive() else 'none yet'})") from None
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
        self._spec, self._context = spec, mp.get_context("spawn")
        with child_environment(SINGLE_THREAD_ENV):
            self.workers = [ProcessWorker(self._context, self.worker_class, spec, i) for i in range(self.config.workers)]
        for worker in self.workers:
            worker.receive()  # construction errors surface here, before the first iteration
        self._pending: set[int] = set()

    def _replace(self, index: int, cause: WorkerProcessDied) -> None:
        """A fresh process for worker `index`, built and ready."""
        self.faults.restarts += 1
        log.warning("rollout %s; started again", cause)
        self.workers[index].close()
        with child_environment(SINGLE_THREAD_ENV):
            self.workers[index] = ProcessWorker(self._context, self.worker_class, self._spec, index)
        self.workers[index].receive()
        self._pids.pop(index, None)  # its new pid is not another restart

    def _sample(self, weights, version, steps, options):
        request = (weights, version, steps, options)
        for worker in self.workers:
            worker.conn.send(request)
        return [self._receive_share(index, request) for index in range(len(self.workers))]

    def _receive_share(self, index: int, request) -> dict:
        for _ in range(3):  # a process that dies three times on one share is not a transient fault
            try:
                return self.workers[index].receive()
            except WorkerProcessDied as exc:
                self.faults.failures += 1
                self._replace(index, exc)
                self.workers[index].conn.send(request)
        raise SfvError(f"rollout worker {index}: its process died 3 times on one share, giving up")

    def submit(self, index, steps, options):
        weights, version = self._published
        self.workers[index].conn.send((weights, version, steps, options))
        self._pending.add(index)

    def poll(self, timeout):
        conns = {self.workers[i].conn: i for i in self._pending}
        done = []
        for conn in wait_for_pipes(list(conns), timeout=timeout):
            index = conns[conn]
            self._pending.discard(index)
            try:
                result = self.workers[index].receive()
            except WorkerProcessDied as exc:
                self.faults.failures += 1
                self._replace(index, exc)
                result = None
            else:
                self._note_pid(index, int(result["worker_pid"]))
            done.append((index, result))
        return done

    def close(self) -> None:
        for worker in self.workers:
            worker.close()
