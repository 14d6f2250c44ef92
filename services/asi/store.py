"""Where ASI jobs live: the store interface, its record types and the in-process store.

A store owns each job's immutable spec (config, phases, reference table) and its
mutable state (means, log-stds, version, pending report buffer, per-component fall
statistics). `report` appends episodes (and folds their fall flags into the statistics)
and, every `episodes_per_update` of them, takes one gradient step atomically, so
concurrent reports never lose or double-use an episode.
"""
from __future__ import annotations

import logging
import struct
import threading
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from learner.errors import SfvError
from services.asi.distribution import InitialStateDistribution, UpdateConfig
from services.asi.fall_weights import FallStats

log = logging.getLogger(__name__)


class StoreUnavailable(SfvError):
    """The backing store cannot be reached; the request may succeed later."""


class TooManyJobs(SfvError):
    """The store already holds its maximum number of jobs."""


@dataclass(frozen=True)
class JobSpec:
    """The part of a job fixed at creation."""

    job_id: str
    config: UpdateConfig
    phases: np.ndarray            # (k,) float64
    reference_states: np.ndarray  # (F, D) float32
    reference_phases: np.ndarray  # (F,) float64

    @property
    def num_components(self) -> int:
        return self.phases.shape[0]

    @property
    def state_dim(self) -> int:
        return self.reference_states.shape[1]

    @property
    def num_frames(self) -> int:
        return self.reference_states.shape[0]


@dataclass(frozen=True)
class JobParams:
    """A snapshot of a job's learned parameters."""

    means: np.ndarray     # (k, D) float64
    log_stds: np.ndarray  # (k, D) float64
    version: int
    pending_episodes: int
    policy_version: int | None = None
    fall_stats: FallStats | None = None  # None: no episode has reported a fall flag yet

    def fall_rates(self) -> np.ndarray:
        """Running fall rate per component (zeros before any flag was reported)."""
        return (self.fall_stats or FallStats.empty(self.means.shape[0])).rates


@dataclass(frozen=True)
class EpisodeBatch:
    """Reported episodes: initial states, the ASI component each came from, discounted returns."""

    states: np.ndarray      # (n, D) float32
    components: np.ndarray  # (n,) int32
    returns: np.ndarray     # (n,) float64

    _HEADER = struct.Struct("<II")  # n, D

    def __len__(self) -> int:
        return self.states.shape[0]

    @staticmethod
    def concatenate(batches: list["EpisodeBatch"]) -> "EpisodeBatch":
        if len(batches) == 1:
            return batches[0]
        return EpisodeBatch(np.concatenate([b.states for b in batches]),
                            np.concatenate([b.components for b in batches]),
                            np.concatenate([b.returns for b in batches]))

    def split(self, n: int) -> tuple["EpisodeBatch", "EpisodeBatch"]:
        """(first n episodes, the rest)."""
        return (EpisodeBatch(self.states[:n], self.components[:n], self.returns[:n]),
                EpisodeBatch(self.states[n:], self.components[n:], self.returns[n:]))

    def to_bytes(self) -> bytes:
        n, d = self.states.shape
        return b"".join((self._HEADER.pack(n, d), self.states.astype("<f4").tobytes(),
                         self.components.astype("<i4").tobytes(), self.returns.astype("<f8").tobytes()))

    @classmethod
    def from_bytes(cls, blob: bytes) -> "EpisodeBatch":
        n, d = cls._HEADER.unpack_from(blob)
        offset = cls._HEADER.size
        states = np.frombuffer(blob, "<f4", n * d, offset).reshape(n, d)
        offset += 4 * n * d
        components = np.frombuffer(blob, "<i4", n, offset)
        offset += 4 * n
        returns = np.frombuffer(blob, "<f8", n, offset)
        return cls(states, components, returns)


@dataclass(frozen=True)
class ReportOutcome:
    version: int
    updated: bool
    pending_episodes: int


def gradient_step(spec: JobSpec, means: np.ndarray, log_stds: np.ndarray,
                  batch: EpisodeBatch) -> tuple[np.ndarray, np.ndarray]:
    """One ASI step on a full batch; shared by every store so they agree bit for bit."""
    before = InitialStateDistribution(spec.phases, means, log_stds)
    after = before.apply_update(batch.states, batch.components, batch.returns, spec.config)
    if after is before:
        log.warning("asi job %s: step rejected (non-finite parameters); batch of %d consumed", spec.job_id, len(batch))
    else:
        log.info("asi job %s: step on %d episodes, mean return %.4g, mean |d mu|/sigma %.3g",
                 spec.job_id, len(batch), float(np.mean(batch.returns)),
                 float(np.mean(np.abs(after.means - means) / before.stds)))
    return after.means, after.log_stds


class ASIStore(ABC):
    """Persistence and atomic update of ASI jobs."""

    @abstractmethod
    def create_job(self, spec: JobSpec, means: np.ndarray, log_stds: np.ndarray) -> tuple[JobSpec, JobParams, bool]:
        """Create the job if absent. Returns (stored spec, current params, created)."""

    @abstractmethod
    def get_spec(self, job_id: str) -> JobSpec | None:
        """The job's immutable spec, or None for an unknown job."""

    @abstractmethod
    def get_params(self, job_id: str) -> JobParams | None:
        """The job's current parameters, or None for an unknown job."""

    @abstractmethod
    def report(self, spec: JobSpec, batch: EpisodeBatch, policy_version: int | None,
               fell: np.ndarray | None = None) -> ReportOutcome:
        """Append episodes; take one gradient step per full batch of episodes_per_update.
        `fell` (n,) bool updates the fall statistics in the same atomic step; None leaves them."""

    def close(self) -> None:
        """Release connections."""


class _MemoryJob:
    def __init__(self, spec: JobSpec, means: np.ndarray, log_stds: np.ndarray):
        self.spec = spec
        self.means = means
        self.log_stds = log_stds
        self.version = 0
        self.policy_version: int | None = None
        self.fall_stats: FallStats | None = None
        self.pending: list[EpisodeBatch] = []
        self.pending_count = 0
        self.lock = threading.Lock()

    def snapshot(self) -> JobParams:
        return JobParams(self.means, self.log_stds, self.version, self.pending_count, self.policy_version,
                         self.fall_stats)


class InMemoryStore(ASIStore):
    """Jobs in this process's memory: the default for a single trainer; lost on exit."""

    def __init__(self, max_jobs: int = 1024):
        self.max_jobs = max_jobs
        self._jobs: dict[str, _MemoryJob] = {}
        self._lock = threading.Lock()

    def create_job(self, spec, means, log_stds):
        with self._lock:
            job = self._jobs.get(spec.job_id)
            if job is not None:
                with job.lock:
                    return job.spec, job.snapshot(), False
            if len(self._jobs) >= self.max_jobs:
                raise TooManyJobs(f"in-memory ASI store: already holds {self.max_jobs} jobs")
            job = _MemoryJob(spec, np.array(means, np.float64), np.array(log_stds, np.float64))
            self._jobs[spec.job_id] = job
            return job.spec, job.snapshot(), True

    def get_spec(self, job_id):
        job = self._jobs.get(job_id)
        return None if job is None else job.spec

    def get_params(self, job_id):
        job = self._jobs.get(job_id)
        if job is None:
            return None
        with job.lock:
            return job.snapshot()

    def report(self, spec, batch, policy_version, fell=None):
        job = self._jobs[spec.job_id]
        per_update = spec.config.episodes_per_update
        updated = False
        with job.lock:
            job.pending.append(batch)
            job.pending_count += len(batch)
            if policy_version is not None:
                job.policy_version = policy_version
            if fell is not None:
                job.fall_stats = (job.fall_stats or FallStats.empty(spec.num_components)).updated(batch.components, fell)
            while job.pending_count >= per_update:
                used, rest = EpisodeBatch.concatenate(job.pending).split(per_update)
                job.means, job.log_stds = gradient_step(spec, job.means, job.log_stds, used)
                job.version += 1
                job.pending = [rest] if len(rest) else []
                job.pending_count = len(rest)
                updated = True
            return ReportOutcome(job.version, updated, job.pending_count)
