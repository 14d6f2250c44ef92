"""Rollout workers as Ray actors: the production transport, fault tolerant.

Weights go out once per iteration through the object store, trajectories come back as numpy
arrays. A worker that dies is restarted by Ray (`max_restarts=-1`); its share of the batch is
handed to a worker that has answered, so an iteration never waits on a dead process. A worker
that hangs past `worker_timeout_s` is killed (and restarted) the same way. A worker that
raises SfvError (ASI server gone for longer than `asi_outage_s`, a request the server
refuses) stops training with that message. A local Ray that dies under the run (its raylet
or GCS killed) is started again with fresh workers, and the iteration it interrupted is
collected again (`ray_restarts`); the driver's learner, ASI server and counters live in the
driver's process and lose nothing. docs/faults.md has the measured numbers.
"""
from __future__ import annotations

import time
import uuid

from learner.errors import SfvError
from services.ray_session import connect_ray, local_ray_alive, restart_local_ray
from services.training.runners.base import WorkerRunner, log

MAX_RAY_RESTARTS_PER_ITERATION = 2  # a Ray that dies again at once is not a transient fault


class LocalRayDied(Exception):
    """The local Ray under this run lost its raylet or GCS."""


class RayRunner(WorkerRunner):
    name = "ray"

    def start(self, spec) -> None:
        import ray

        self._spec = spec  # kept for a restart of the local Ray
        connect_ray(self.config.ray_address, num_cpus=max(self.config.workers, 1))
        # The spec (the motion, hand-over states: > 100 kB) is held by one small actor this runner
        # owns; a worker's constructor takes only its name and fetches the spec, so a restarted
        # worker fetches it again. A spec passed as an argument (or a reference to it) lives in
        # the object store, which Ray does not keep for an actor's restart: ray-project/ray#53727,
        # and an error line per training run saying so.
        holder_name = f"sfv-spec-{uuid.uuid4().hex}"
        self._spec_holder = _start_spec_holder(spec, holder_name)
        remote_cls = ray.remote(num_cpus=1, max_restarts=-1, max_task_retries=0)(_spec_from_holder(self.worker_class))
        self.workers = [remote_cls.remote(holder_name, i) for i in range(self.config.workers)]
        pids = ray.get([w.pid.remote() for w in self.workers])  # construction errors surface here
        self._pids = dict(enumerate(pids))
        self._restarts_seen = [0] * len(self.workers)  # Ray's own restart count per actor, as last read
        self._async_pending: dict = {}  # object ref -> (worker index, submitted at): the asynchronous interface
        self._restart_watch: dict[int, int] = {}  # lost worker -> Ray's restart count for it when it was lost

    def _sample(self, weights, version, steps, options):
        for attempt in range(MAX_RAY_RESTARTS_PER_ITERATION + 1):
            try:
                return self._sample_once(weights, version, steps, options)
            except Exception as exc:  # noqa: BLE001  (whatever Ray raised: only a dead local Ray is handled here)
                if self.config.ray_address or local_ray_alive():
                    raise
                if attempt == MAX_RAY_RESTARTS_PER_ITERATION:
                    raise SfvError(f"the local Ray died {attempt + 1} times in iteration {version + 1}, giving up "
                                   f"(last: {_first_line(exc)})") from None
                self._restart_local_ray(version, exc)
        raise AssertionError("unreachable")

    def _sample_once(self, weights, version, steps, options):
        import ray

        if not local_ray_alive():
            raise LocalRayDied("found dead before the iteration")
        results = _Iteration(self, ray.put(weights), version, steps, options).run()
        self._count_restarts()
        return results

    def _restart_local_ray(self, version: int, cause: Exception) -> None:
        self.faults.ray_restarts += 1
        log.warning("the local Ray died (%s); starting it again with fresh workers, iteration %d is collected again",
                    _first_line(cause), version + 1)
        restart_local_ray(num_cpus=max(self.config.workers, 1))
        self.start(self._spec)
        if getattr(self, "_published", None) is not None:  # the old object store went with the old Ray
            self.publish(*self._published[1:])

    # ------------------------------------------------------- the asynchronous interface
    def publish(self, weights, version):
        import ray

        self._published = (ray.put(weights), weights, version)  # one put per version, however many shares use it

    def submit(self, index, steps, options):
        ref, _, version = self._published
        self._async_pending[self.workers[index].sample.remote(ref, version, steps, **options)] = (index, time.monotonic())

    def poll(self, timeout):
        if not self._async_pending:
            return []
        try:
            return self._poll_once(timeout)
        except Exception as exc:  # noqa: BLE001  (only a dead local Ray is handled here)
            if self.config.ray_address or local_ray_alive():
                raise
            lost = sorted(index for index, _ in self._async_pending.values())
            self._async_pending.clear()
            self._restart_local_ray(int(self._published[2]), exc)
            return [(index, None) for index in lost]

    def _poll_once(self, timeout):
        """Each share has its own deadline, `timeout` after it was submitted: a worker that hangs
        is found while the others keep answering (they would fill every batch without it)."""
        import ray

        pending = self._async_pending
        done: list = []
        while pending and not done:
            first_due = min(started for _, started in pending.values()) + timeout
            ray.wait(list(pending), num_returns=1, timeout=max(0.0, first_due - time.monotonic()))
            ready, _ = ray.wait(list(pending), num_returns=len(pending), timeout=0)  # whatever is done
            for ref in ready:
                index, _ = pending.pop(ref)
                done.append((index, self._answer(ref, index)))
            now = time.monotonic()
            for ref, (index, started) in list(pending.items()):
                if now - started >= timeout:  # overdue: the worker hangs; kill it (Ray restarts it)
                    del pending[ref]
                    ray.kill(self.workers[index], no_restart=False)
                    self._lost(index, f"no answer within {timeout:g} s, killed")
                    done.append((index, None))
        if self._restart_watch:
            self._watch_restarts({index for index, result in done if result is not None})
        return done

    def _watch_restarts(self, answered: set[int]) -> None:
        """Ray's restart counts, read while a lost worker's restart is not yet counted: the other
        workers may fill every batch while it restarts, so its next answer may come late or never."""
        self._count_restarts()
        if self._restarts_seen is None:
            self._restart_watch.clear()
            return
        for index, count in list(self._restart_watch.items()):
            if self._restarts_seen[index] > count or index in answered:  # counted, or it answers without having died
                del self._restart_watch[index]

    def _answer(self, ref, index: int) -> dict | None:
        result, reason = _fetch_share(ref, index)
        if result is None:
            self._lost(index, reason)
        else:
            self._note_pid(index, int(result["worker_pid"]))  # restarts by changed pids, where Ray's counts are unavailable
        return result

    def close(self) -> None:
        """Kill this run's workers and spec holder now. Left to Ray's reference counting, an
        asynchronous run's actors outlived it (their handles sit in a reference cycle with the
        in-flight shares) and held the CPUs the next run's workers waited for, forever."""
        import ray

        actors = list(getattr(self, "workers", [])) + [a for a in [getattr(self, "_spec_holder", None)] if a is not None]
        self.workers, self._spec_holder, self._async_pending = [], None, {}
        if not ray.is_initialized():
            return
        for actor in actors:
            try:
                ray.kill(actor, no_restart=True)
            except Exception as exc:  # noqa: BLE001  (an actor already gone, a Ray shutting down)
                log.debug("could not kill a Ray actor at close (%s)", exc)

    def _lost(self, index: int, reason: str) -> None:
        self.faults.failures += 1
        if self._restarts_seen is not None:
            self._restart_watch.setdefault(index, self._restarts_seen[index])
        log.warning("rollout worker %d failed (%s); it is handed a new share", index, reason)

    def _note_pid(self, index: int, pid: int) -> None:
        if self._restarts_seen is None:  # no restart counts from Ray: a changed pid is the sign
            super()._note_pid(index, pid)
        else:
            self._pids[index] = pid

    def _count_restarts(self) -> None:
        """Restarts as Ray's control store counts them per actor. Counting changed pids misses a
        process that dies before it answers anything: a pid() call queued on an actor while Ray
        restarts it can fail (ActorUnavailableError) rather than wait, seen on a loaded machine."""
        if self._restarts_seen is None:
            return
        try:
            import ray._private.state as gcs_state

            counts = [int(gcs_state.actors(actor_id=w._actor_id.hex())["NumRestarts"]) for w in self.workers]
        except Exception as exc:  # a Ray without this table: fall back to watching the pids
            log.warning("Ray's actor restart counts are unavailable (%s); counting changed worker pids instead", exc)
            self._restarts_seen = None
            return
        for index, (count, seen) in enumerate(zip(counts, self._restarts_seen)):
            if count > seen:
                self.faults.restarts += count - seen
                log.warning("rollout worker %d was restarted (%d time%s since the last iteration)", index, count - seen,
                            "" if count - seen == 1 else "s")
        self._restarts_seen = counts


class _SpecHolder:
    """The rollout spec, for the workers' constructors (first start and every restart)."""

    def __init__(self, spec):
        self.spec = spec

    def get(self):
        return self.spec


def _start_spec_holder(spec, name: str):
    """A named holder of `spec`, owned by this driver (it goes when the driver's Ray session does)."""
    import ray

    holder = ray.remote(num_cpus=0, max_restarts=0)(_SpecHolder).options(name=name).remote(spec)
    ray.get(holder.get.remote())  # up and holding before any worker asks
    return holder


def _spec_from_holder(worker_class):
    """`worker_class` built from `(holder_name, index)`: the spec is fetched in the actor's process."""

    class FromHolder(worker_class):
        def __init__(self, holder_name: str, index: int):
            import ray

            super().__init__(ray.get(ray.get_actor(holder_name).get.remote()), index)

    FromHolder.__name__ = FromHolder.__qualname__ = worker_class.__name__  # Ray's actor name in logs and `ray list`
    return FromHolder


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
                    self.lost(index, f"no answer within {timeout:g} s, killed")
                continue
            for ref in ready:
                self._receive(ref)
        return self.results

    def _receive(self, ref) -> None:
        index = self.pending.pop(ref)
        result, reason = _fetch_share(ref, index)
        if result is None:
            self.lost(index, reason)
        else:
            self.results.append(result)
            if self.orphans:  # this worker is free now: it takes over a lost share
                self.orphans.pop(0)
                self.submit(index)
            else:
                self.idle.append(index)


def _fetch_share(ref, index: int) -> tuple[dict | None, str]:
    """A worker's finished share, or (None, why it was lost). A worker's SfvError (a refused
    request, a lasting ASI outage: not the worker's fault) stops training; a dead local Ray
    raises LocalRayDied for the runner to start it again."""
    import ray
    from ray.exceptions import RayError, RayTaskError

    try:
        return ray.get(ref), ""
    except RayTaskError as exc:
        cause = getattr(exc, "cause", None)
        if isinstance(cause, SfvError):
            raise SfvError(f"rollout worker {index}: {cause}") from None
        return None, f"{type(cause or exc).__name__}: {str(cause or exc).splitlines()[0][:200]}"
    except RayError as exc:  # the process died (Ray restarts it) or its result was lost
        if not local_ray_alive():  # not the worker: the whole local Ray went
            raise LocalRayDied(type(exc).__name__) from None
        return None, type(exc).__name__


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return f"{type(exc).__name__}: {text.splitlines()[0][:200]}" if text else type(exc).__name__
