"""Rollout workers as Ray actors: the production transport, fault tolerant.

Weights go out once per iteration through the object store, trajectories come back as numpy
arrays. A worker that dies is restarted by Ray (`max_restarts=-1`); its share of the batch is
handed to a worker that has answered, so an iteration never waits on a dead process. A worker
that hangs past `worker_timeout_s` is killed (and restarted) the same way. A worker that
raises SfvError (ASI server gone for longer than `asi_outage_s`, a request the server
refuses) stops training with that message. docs/faults.md has the measured numbers.
"""
from __future__ import annotations

import time

from learner.errors import SfvError
from services.ray_session import connect_ray
from services.training.runners.base import WorkerRunner, log


class RayRunner(WorkerRunner):
    name = "ray"

    def start(self, spec) -> None:
        import ray

        connect_ray(self.config.ray_address, num_cpus=max(self.config.workers, 1))
        remote_cls = ray.remote(num_cpus=1, max_restarts=-1, max_task_retries=0)(self.worker_class)
        self.workers = [remote_cls.remote(spec, i) for i in range(self.config.workers)]
        pids = ray.get([w.pid.remote() for w in self.workers])  # construction errors surface here
        self._pids = dict(enumerate(pids))
        self._pid_probes: dict = {}  # pid() calls queued on workers that died or were killed -> index

    def _sample(self, weights, version, steps, options):
        import ray

        results = _Iteration(self, ray.put(weights), version, steps, options).run()
        self._note_probed_pids()
        return results

    def probe_pid(self, index: int) -> None:
        """Queue a pid() call on a worker Ray is restarting: it runs first in the new process, so
        the restart is seen even if that process dies or hangs before it answers a sample()."""
        self._pid_probes[self.workers[index].pid.remote()] = index

    def _note_probed_pids(self) -> None:
        """Answered probes, before this iteration's results (an actor runs its calls in order, so a
        probe queued before a sample() has answered when that sample() has)."""
        import ray
        from ray.exceptions import RayError

        if not self._pid_probes:
            return
        ready, _ = ray.wait(list(self._pid_probes), num_returns=len(self._pid_probes), timeout=0)
        for ref in ready:
            index = self._pid_probes.pop(ref)
            try:
                self._note_pid(index, int(ray.get(ref)))
            except RayError:  # that process died as well; its successor's answers will show
                pass


class _Iteration:
    """One share per worker; a share lost to a dead or hung worker goes to a worker that has answered."""

    def __init__(self, runner: RayRunner, weights_ref, version: int, steps: int, options: dict):
        self.runner, self.workers = runner, runner.workers
        self.weights_ref, self.version, self.steps, self.options = weights_ref, version, steps, options
        self.pending: dict = {}  # object ref -> worker index
        self.results: list[dict] = []
        self.idle: list[int] = []  # answered, free
        self.orphans: list[int] = []  # lost shares, no taker yet
        self.failures = 0
        self.max_failures = 3 * len(self.workers)  # beyond this the fault is not transient: stop, do not spin

    def submit(self, index: int) -> None:
        self.pending[self.workers[index].sample.remote(self.weights_ref, self.version, self.steps, **self.options)] = index

    def lost(self, index: int, reason: str) -> None:
        self.failures += 1
        self.runner.faults.failures += 1
        if self.failures > self.max_failures:
            raise SfvError(f"rollout workers failed {self.failures} times in iteration {self.version + 1}, giving up "
                           f"(last: worker {index}: {reason})")
        log.warning("rollout worker %d failed (%s); its share is reissued", index, reason)
        if self.idle:
            self.submit(self.idle.pop(0))
        else:
            self.orphans.append(index)

    def run(self) -> list[dict]:
        import ray

        timeout = self.runner.config.worker_timeout_s
        takebacks = 0
        for index in range(len(self.workers)):
            self.submit(index)
        while self.pending or self.orphans:
            if not self.pending:  # nobody left to answer: the restarted workers take their own shares back
                time.sleep(min(5.0, 0.5 * 2 ** takebacks))  # give Ray time to restart them; do not burn retries
                takebacks += 1
                for index in self.orphans:
                    self.submit(index)
                self.orphans.clear()
            ready, _ = ray.wait(list(self.pending), num_returns=1, timeout=timeout)
            if not ready:  # every outstanding worker hangs: kill them (Ray restarts them)
                for ref, index in list(self.pending.items()):
                    del self.pending[ref]
                    ray.kill(self.workers[index], no_restart=False)
                    self.runner.probe_pid(index)
                    self.lost(index, f"no answer within {timeout:g} s, killed")
                continue
            for ref in ready:
                self._receive(ref)
        return self.results

    def _receive(self, ref) -> None:
        import ray
        from ray.exceptions import RayError, RayTaskError

        index = self.pending.pop(ref)
        try:
            result = ray.get(ref)
        except RayTaskError as exc:
            cause = getattr(exc, "cause", None)
            if isinstance(cause, SfvError):  # a refused request or a lasting outage: not the worker's fault
                raise SfvError(f"rollout worker {index}: {cause}") from None
            self.lost(index, f"{type(cause or exc).__name__}: {str(cause or exc).splitlines()[0][:200]}")
        except RayError as exc:  # the process died (Ray restarts it) or its result was lost
            self.runner.probe_pid(index)
            self.lost(index, type(exc).__name__)
        else:
            self.results.append(result)
            if self.orphans:  # this worker is free now: it takes over a lost share
                self.orphans.pop(0)
                self.submit(index)
            else:
                self.idle.append(index)
