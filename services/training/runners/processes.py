"""Rollout workers in plain spawned processes that talk over pipes: training without Ray
(a GPU box without the Ray wheel, `bench/scripts/scaling.py`).

Worker processes get one BLAS/OpenMP thread each, as Ray gives its 1-CPU actors. A worker
that raises stops the run with its error; a worker process that dies (killed, out of memory)
is started again and its share handed to it again, with a line saying so (`worker_restarts`).
A worker that hangs (stopped, deadlocked) is found by its share's own deadline,
`worker_timeout_s` after the share was sent, is killed and started again the same way; in the
asynchronous interface the other workers go on answering meanwhile (as `RayRunner` does).
"""
from __future__ import annotations

import contextlib
import multiprocessing as mp
import os
import signal
import time
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
        self.kill()

    def kill(self) -> None:
        """SIGKILL (a stopped process dies too), then reap it."""
        if self.proc.is_alive():
            self.proc.kill()
            self.proc.join()
        self.conn.close()

    def hung(self, timeout: float) -> WorkerProcessDied:
        """Kill this worker, which gave no answer within `timeout` s; the cause to report."""
        pid = self.proc.pid
        self.kill()
        return WorkerProcessDied(f"worker {self.index}: no answer within {timeout:g} s, killed (process {pid})")


class ProcessRunner(WorkerRunner):
    name = "processes"

    def start(self, spec) -> None:
        self._spec, self._context = spec, mp.get_context("spawn")
        with child_environment(SINGLE_THREAD_ENV):
            self.workers = [ProcessWorker(self._context, self.worker_class, spec, i) for i in range(self.config.workers)]
        for worker in self.workers:
            worker.receive()  # construction errors surface here, before the first iteration
        self._pending: dict[int, float] = {}  # the asynchronous interface: worker index -> share sent at

    def _replace(self, index: int, cause: WorkerProcessDied) -> None:
        """Worker `index` lost its share to `cause`: counted, and a fresh process built and ready."""
        self.faults.failures += 1
        self.faults.restarts += 1
        log.warning("rollout %s; started again", cause)
        self.workers[index].close()
        with child_environment(SINGLE_THREAD_ENV):
            self.workers[index] = ProcessWorker(self._context, self.worker_class, self._spec, index)
        self.workers[index].receive()
        self._pids.pop(index, None)  # its new pid is not another restart

    def _sample(self, weights, version, steps, options):
        """Every worker's share; one lost to a dead or hung process is sent again to its new
        process (three losses of one share stop the run)."""
        request = (weights, version, steps, options)
        results: dict[int, dict] = {}
        losses = dict.fromkeys(range(len(self.workers)), 0)
        sent = {}
        for index, worker in enumerate(self.workers):
            worker.conn.send(request)
            sent[index] = time.monotonic()
        timeout = float(self.config.worker_timeout_s)
        while sent:
            for index, outcome in self._wait(sent, timeout):
                if isinstance(outcome, WorkerProcessDied):
                    losses[index] += 1
                    if losses[index] == 3:  # not a transient fault
                        raise SfvError(f"rollout worker {index}: its process died 3 times on one share, giving up ({outcome})")
                    self._replace(index, outcome)
                    self.workers[index].conn.send(request)
                    sent[index] = time.monotonic()
                else:
                    results[index] = outcome
        return [results[index] for index in range(len(self.workers))]

    def _wait(self, sent: dict[int, float], timeout: float) -> list[tuple[int, object]]:
        """Wait, no later than the first share's deadline (`timeout` s after it was sent), for the
        workers in `sent` (index -> sent at); (index, share or the `WorkerProcessDied` that lost
        it) for each that answered, died or is overdue (killed here). Those leave `sent`."""
        wait_s = max(0.0, min(sent.values()) + timeout - time.monotonic())
        conns = {self.workers[index].conn: index for index in sent}
        out = []
        for conn in wait_for_pipes(list(conns), timeout=wait_s):
            index = conns[conn]
            del sent[index]
            try:
                out.append((index, self.workers[index].receive()))
            except WorkerProcessDied as exc:
                out.append((index, exc))
        now = time.monotonic()
        for index, started in list(sent.items()):
            if now - started >= timeout:  # overdue: the process hangs
                del sent[index]
                out.append((index, self.workers[index].hung(timeout)))
        return out

    def submit(self, index, steps, options):
        weights, version = self._published
        self.workers[index].conn.send((weights, version, steps, options))
        self._pending[index] = time.monotonic()

    def poll(self, timeout):
        """The shares done by now, at least one unless nothing is pending. Each share has its own
        deadline, `timeout` s after it was submitted: a worker past it is killed and started
        again, and its share comes back as None, while the others go on answering."""
        done = []
        while self._pending and not done:
            for index, outcome in self._wait(self._pending, timeout):
                if isinstance(outcome, WorkerProcessDied):
                    self._replace(index, outcome)
                    done.append((index, None))
                else:
                    self._note_pid(index, int(outcome["worker_pid"]))
                    done.append((index, outcome))
        return done

    def close(self) -> None:
        for worker in self.workers:
            worker.close()
