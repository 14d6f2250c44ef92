"""ASI jobs kept in Redis, so a restarted server carries on with the same parameters and version.

Keys per job (binary values are little-endian raw numbers):
  sfv:asi:{job}             hash: config (json), phases (<f8), means (<f8), log_stds (<f8), version
  sfv:asi:{job}:reference   hash: states (<f4, F*D), phases (<f8, F), dims (json)
  sfv:asi:{job}:pending     list of EpisodeBatch chunks (one per report), oldest first
  sfv:asi:{job}:pending_n   number of episodes in the pending list
  sfv:asi:{job}:policy      latest reported policy_version
  sfv:asi:{job}:falls       FallStats (<f8, 2k: decayed falls, decayed episodes); absent until a flag is reported
  sfv:asi:jobs              set of job ids

Reports only RPUSH to the tail of the pending list (atomically with INCRBY of the count).
A report carrying fall flags does so in a MULTI/EXEC guarded by WATCH on the falls key,
which also writes the updated FallStats: the read-modify-write of the decayed counts never
loses a concurrent report's flags, and the append and its flags land together or not at all.
An update reads the oldest chunks, and in one MULTI/EXEC guarded by WATCH on the job hash
writes the new parameters and version, trims the used chunks and puts any leftover back
at the head. Only updaters write the job hash, so two servers sharing one Redis never
apply the same batch twice; appends never conflict with the WATCH.
"""
from __future__ import annotations

import json
import logging
import threading
from dataclasses import asdict
from urllib.parse import urlsplit, urlunsplit

import numpy as np
import redis
from redis.backoff import ExponentialBackoff
from redis.retry import Retry

from learner.errors import SfvError
from services.asi.distribution import UpdateConfig
from services.asi.fall_weights import FallStats
from services.asi.store import ASIStore, EpisodeBatch, JobParams, JobSpec, ReportOutcome, StoreUnavailable, TooManyJobs, gradient_step

log = logging.getLogger(__name__)

_JOBS_KEY = "sfv:asi:jobs"
_CHUNKS_PER_READ = 64
_MAX_WATCH_RETRIES = 50


def redact_url(url: str) -> str:
    """The URL with any password replaced by '***' (safe for logs and error messages)."""
    parts = urlsplit(url)
    if parts.password is None:
        return url
    user = parts.username or ""
    host = parts.hostname or ""
    if parts.port is not None:
        host = f"{host}:{parts.port}"
    return urlunsplit((parts.scheme, f"{user}:***@{host}", parts.path, parts.query, parts.fragment))


def _f64(blob: bytes, shape) -> np.ndarray:
    return np.frombuffer(blob, "<f8").reshape(shape)


class RedisStore(ASIStore):
    """ASI jobs in Redis at `url` (redis://[:password@]host:port/db or rediss:// for TLS)."""

    def __init__(self, url: str, max_jobs: int = 1024, connect_timeout: float = 1.0, socket_timeout: float = 5.0):
        self.url = url
        self.safe_url = redact_url(url)
        self.max_jobs = max_jobs
        self._password = urlsplit(url).password
        self._update_locks: dict[str, threading.Lock] = {}
        self._locks_guard = threading.Lock()
        self._check_reachable(connect_timeout)
        self._redis = redis.Redis.from_url(
            url, socket_connect_timeout=connect_timeout, socket_timeout=socket_timeout,
            retry=Retry(ExponentialBackoff(cap=0.5, base=0.05), retries=2), health_check_interval=30)

    def _check_reachable(self, timeout: float) -> None:
        # A dedicated client without retries, so an unreachable or silent Redis fails in ~timeout.
        probe = None
        try:
            probe = redis.Redis.from_url(self.url, socket_connect_timeout=timeout, socket_timeout=2 * timeout,
                                         retry=Retry(ExponentialBackoff(), retries=0))
            probe.ping()
        except ValueError as exc:
            raise SfvError(f"redis url {self.safe_url}: {self._scrub(exc)}") from None
        except redis.RedisError as exc:
            raise SfvError(f"redis at {self.safe_url}: unreachable ({type(exc).__name__}: {self._scrub(exc)})") from None
        finally:
            if probe is not None:
                probe.close()

    def _scrub(self, exc: Exception) -> str:
        text = str(exc).splitlines()[0] if str(exc) else ""
        return text.replace(self._password, "***") if self._password else text

    def _unavailable(self, exc: redis.RedisError) -> StoreUnavailable:
        return StoreUnavailable(f"redis at {self.safe_url}: {type(exc).__name__}: {self._scrub(exc)}")

    def close(self) -> None:
        self._redis.close()

    # --- keys -------------------------------------------------------------------------------
    @staticmethod
    def _keys(job_id: str) -> tuple[str, str, str, str, str]:
        base = f"sfv:asi:{job_id}"
        return base, f"{base}:reference", f"{base}:pending", f"{base}:pending_n", f"{base}:policy"

    @staticmethod
    def _falls_key(job_id: str) -> str:
        return f"sfv:asi:{job_id}:falls"

    def _update_lock(self, job_id: str) -> threading.Lock:
        with self._locks_guard:
            return self._update_locks.setdefault(job_id, threading.Lock())

    # --- ASIStore ---------------------------------------------------------------------------
    def create_job(self, spec, means, log_stds):
        main, ref, pending, pending_n, policy = self._keys(spec.job_id)
        try:
            with self._redis.pipeline() as pipe:
                while True:
                    try:
                        pipe.watch(main, _JOBS_KEY)
                        if pipe.exists(main):
                            pipe.unwatch()
                            return self.get_spec(spec.job_id), self.get_params(spec.job_id), False
                        if pipe.scard(_JOBS_KEY) >= self.max_jobs:
                            pipe.unwatch()
                            raise TooManyJobs(f"redis ASI store {self.safe_url}: already holds {self.max_jobs} jobs")
                        pipe.multi()
                        pipe.delete(ref, pending, pending_n, policy, self._falls_key(spec.job_id))
                        pipe.hset(ref, mapping={
                            "states": np.ascontiguousarray(spec.reference_states, "<f4").tobytes(),
                            "phases": np.ascontiguousarray(spec.reference_phases, "<f8").tobytes(),
                            "dims": json.dumps([spec.num_frames, spec.state_dim])})
                        pipe.hset(main, mapping={
                            "config": json.dumps(asdict(spec.config)),
                            "phases": np.ascontiguousarray(spec.phases, "<f8").tobytes(),
                            "means": np.ascontiguousarray(means, "<f8").tobytes(),
                            "log_stds": np.ascontiguousarray(log_stds, "<f8").tobytes(),
                            "version": 0})
                        pipe.set(pending_n, 0)
                        pipe.sadd(_JOBS_KEY, spec.job_id)
                        pipe.execute()
                        return spec, JobParams(np.asarray(means, np.float64), np.asarray(log_stds, np.float64), 0, 0), True
                    except redis.WatchError:
                        continue
        except redis.RedisError as exc:
            raise self._unavailable(exc) from None

    def get_spec(self, job_id):
        main, ref, *_ = self._keys(job_id)
        try:
            with self._redis.pipeline(transaction=True) as pipe:
                pipe.hmget(main, "config", "phases")
                pipe.hmget(ref, "states", "phases", "dims")
                (config, phases), (states, ref_phases, dims) = pipe.execute()
        except redis.RedisError as exc:
            raise self._unavailable(exc) from None
        if config is None or states is None:
            return None
        num_frames, state_dim = json.loads(dims)
        return JobSpec(job_id=job_id, config=UpdateConfig(**json.loads(config)),
                       phases=np.frombuffer(phases, "<f8"),
                       reference_states=np.frombuffer(states, "<f4").reshape(num_frames, state_dim),
                       reference_phases=np.frombuffer(ref_phases, "<f8"))

    def get_params(self, job_id):
        main, _, _, pending_n, policy = self._keys(job_id)
        try:
            with self._redis.pipeline(transaction=True) as pipe:
                pipe.hmget(main, "phases", "means", "log_stds", "version")
                pipe.get(pending_n)
                pipe.get(policy)
                pipe.get(self._falls_key(job_id))
                (phases, means, log_stds, version), pending, policy_version, falls = pipe.execute()
        except redis.RedisError as exc:
            raise self._unavailable(exc) from None
        if means is None:
            return None
        k = len(phases) // 8
        return JobParams(_f64(means, (k, -1)), _f64(log_stds, (k, -1)), int(version), int(pending or 0),
                         None if policy_version is None else int(policy_version),
                         None if falls is None else FallStats.from_bytes(falls, k))

    def report(self, spec, batch, policy_version, fell=None):
        try:
            if fell is None:
                with self._redis.pipeline(transaction=True) as pipe:
                    self._queue_append(pipe, spec.job_id, batch, policy_version)
                    total = pipe.execute()[1]
            else:
                total = self._append_with_falls(spec, batch, policy_version, fell)
            updated = False
            if total >= spec.config.episodes_per_update:
                with self._update_lock(spec.job_id):
                    while self._try_update(spec):
                        updated = True
            params = self.get_params(spec.job_id)
        except redis.RedisError as exc:
            raise self._unavailable(exc) from None
        return ReportOutcome(params.version, updated, params.pending_episodes)

    def _queue_append(self, pipe, job_id: str, batch: EpisodeBatch, policy_version: int | None) -> None:
        """Queue the report's append on `pipe`; its second reply is the new pending count."""
        _, _, pending, pending_n, policy = self._keys(job_id)
        pipe.rpush(pending, batch.to_bytes())
        pipe.incrby(pending_n, len(batch))
        if policy_version is not None:
            pipe.set(policy, policy_version)

    def _append_with_falls(self, spec: JobSpec, batch: EpisodeBatch, policy_version: int | None,
                           fell: np.ndarray) -> int:
        """The append and the fall statistics' update in one transaction; returns the pending count."""
        falls_key = self._falls_key(spec.job_id)
        with self._redis.pipeline() as pipe:
            for _ in range(_MAX_WATCH_RETRIES):
                try:
                    pipe.watch(falls_key)
                    stats = FallStats.from_bytes(pipe.get(falls_key), spec.num_components)
                    pipe.multi()
                    self._queue_append(pipe, spec.job_id, batch, policy_version)
                    pipe.set(falls_key, stats.updated(batch.components, fell).to_bytes())
                    return pipe.execute()[1]
                except redis.WatchError:
                    continue
        raise StoreUnavailable(f"redis at {self.safe_url}: job {spec.job_id!r}: fall statistics kept conflicting "
                               f"with other reports ({_MAX_WATCH_RETRIES} tries); retry")

    def _try_update(self, spec: JobSpec) -> bool:
        """One gradient step if a full batch is pending; False if not (or if it kept conflicting)."""
        main, _, pending, pending_n, _ = self._keys(spec.job_id)
        per_update = spec.config.episodes_per_update
        with self._redis.pipeline() as pipe:
            for _ in range(_MAX_WATCH_RETRIES):
                try:
                    pipe.watch(main)
                    if int(pipe.get(pending_n) or 0) < per_update:
                        pipe.unwatch()
                        return False
                    chunks, used = self._read_head(pipe, pending, per_update)
                    if used < per_update:  # count ahead of the list: never expected; do not step
                        pipe.unwatch()
                        return False
                    phases, means, log_stds, version = pipe.hmget(main, "phases", "means", "log_stds", "version")
                    shape = (len(phases) // 8, -1)
                    batch, rest = EpisodeBatch.concatenate(chunks).split(per_update)
                    new_means, new_log_stds = gradient_step(spec, _f64(means, shape), _f64(log_stds, shape), batch)
                    pipe.multi()
                    pipe.hset(main, mapping={"means": np.ascontiguousarray(new_means, "<f8").tobytes(),
                                             "log_stds": np.ascontiguousarray(new_log_stds, "<f8").tobytes(),
                                             "version": int(version) + 1})
                    pipe.ltrim(pending, len(chunks), -1)
                    if len(rest):
                        pipe.lpush(pending, rest.to_bytes())
                    pipe.decrby(pending_n, per_update)
                    pipe.execute()
                    return True
                except redis.WatchError:
                    continue
        log.warning("asi job %s: update kept conflicting with another server; will retry on the next report",
                    spec.job_id)
        return False

    @staticmethod
    def _read_head(pipe, pending: str, wanted: int) -> tuple[list[EpisodeBatch], int]:
        """The oldest chunks holding at least `wanted` episodes (fewer if the list runs out)."""
        chunks: list[EpisodeBatch] = []
        have = 0
        start = 0
        while have < wanted:
            blobs = pipe.lrange(pending, start, start + _CHUNKS_PER_READ - 1)
            if not blobs:
                break
            for blob in blobs:
                chunks.append(EpisodeBatch.from_bytes(blob))
                have += len(chunks[-1])
                if have >= wanted:
                    break
            start += len(blobs)
        return chunks, have
