"""Client of the ASI initial-state service, used inside rollout workers.

Arrays cross the wire as little-endian raw bytes (see proto/README.md) and come back as
numpy arrays. Transient failures (UNAVAILABLE, DEADLINE_EXCEEDED) are retried with
exponential backoff and jitter. A report that still fails is dropped and counted in
`dropped_reports` -- losing a few episodes only delays an ASI step, while stopping a
rollout worker would stall training. `sample`, `create_job` and `get_distribution`
raise SfvError once retries are exhausted. Any other error (INVALID_ARGUMENT,
NOT_FOUND, UNAUTHENTICATED, ...) is a bug or misconfiguration: no retry, SfvError.

Retrying a report whose first attempt timed out after the server applied it counts
those episodes twice; at 2000 episodes per step that is harmless noise.
"""
from __future__ import annotations

import logging
import random
import threading
import time
from pathlib import Path
from typing import NamedTuple

import grpc
import numpy as np

from learner.errors import SfvError
from proto import asi_pb2, asi_pb2_grpc

log = logging.getLogger(__name__)

MODES = {"asi": asi_pb2.ASI, "rsi": asi_pb2.RSI, "fsi": asi_pb2.FSI}
BASELINES = {"component_mean": asi_pb2.COMPONENT_MEAN, "none": asi_pb2.NONE}
RETRYABLE = (grpc.StatusCode.UNAVAILABLE, grpc.StatusCode.DEADLINE_EXCEEDED)
MAX_MESSAGE_BYTES = 64 * 1024 * 1024
REPORT_CHUNK = 16384  # episodes per ReportEpisodes call; keeps messages far below the limit


class JobInfo(NamedTuple):
    version: int
    created: bool
    state_dim: int
    num_components: int
    num_reference_frames: int


class InitialStates(NamedTuple):
    states: np.ndarray      # (count, D) float32
    phases: np.ndarray      # (count,) float64: the component's phase (ASI) or the frame's phase (RSI/FSI)
    components: np.ndarray  # (count,) int32: ASI component, -1 for RSI/FSI
    version: int            # distribution version the states came from


class Distribution(NamedTuple):
    means: np.ndarray   # (k, D) float64
    stds: np.ndarray    # (k, D) float64
    phases: np.ndarray  # (k,) float64
    version: int
    pending_episodes: int
    update_rule: str = "gradient"
    weights: np.ndarray | None = None     # (k,) probability of each component in the next ASI draw
    fall_rates: np.ndarray | None = None  # (k,) running fall rate of each component's episodes


class _RetriesExhausted(Exception):
    def __init__(self, error: grpc.RpcError, retries: int):
        super().__init__(error.details())
        self.error = error
        self.retries = retries


def _f64_bytes(values) -> bytes:
    return b"" if values is None else np.ascontiguousarray(values, "<f8").tobytes()


class ASIClient:
    """Talks to one job of the ASI service at `address` (host:port)."""

    def __init__(self, address: str, job_id: str, token: str | None = None, timeout: float = 5.0,
                 max_retries: int = 5, backoff: float = 0.1, max_backoff: float = 2.0,
                 tls_root_cert: str | Path | None = None):
        self.address = address
        self.job_id = job_id
        self.timeout = timeout
        self.max_retries = max_retries
        self.backoff = backoff
        self.max_backoff = max_backoff
        self.dropped_reports = 0  # episodes given up on after retries
        self.retries = 0          # retry attempts made so far (all calls)
        self._last_version = 0
        self._counter_lock = threading.Lock()
        self._metadata = (("authorization", f"Bearer {token}"),) if token else ()
        options = [("grpc.max_receive_message_length", MAX_MESSAGE_BYTES),
                   ("grpc.max_send_message_length", MAX_MESSAGE_BYTES),
                   # Reconnect quickly after an outage; gRPC's default backoff grows to minutes.
                   ("grpc.initial_reconnect_backoff_ms", 100),
                   ("grpc.min_reconnect_backoff_ms", 100),
                   ("grpc.max_reconnect_backoff_ms", int(max_backoff * 1000))]
        if tls_root_cert is not None:
            try:
                root = Path(tls_root_cert).read_bytes()
            except OSError as exc:
                raise SfvError(f"{tls_root_cert}: cannot read TLS root certificate ({exc.strerror})") from None
            self._channel = grpc.secure_channel(address, grpc.ssl_channel_credentials(root), options)
        else:
            self._channel = grpc.insecure_channel(address, options)
        self._stub = asi_pb2_grpc.InitialStateServiceStub(self._channel)

    # --- plumbing ---------------------------------------------------------------------------
    def close(self) -> None:
        self._channel.close()

    def __enter__(self) -> "ASIClient":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _call(self, rpc, request, outage_s: float = 0.0, what: str = "call"):
        """Unary call with retries on transient codes: `max_retries` of them, and beyond that
        for as long as `outage_s` seconds from the first attempt (a caller that cannot go on
        without the answer waits out a server restart). Raises _RetriesExhausted or grpc.RpcError."""
        deadline = time.monotonic() + outage_s
        attempt = 0
        while True:
            try:
                return rpc(request, timeout=self.timeout, metadata=self._metadata)
            except grpc.RpcError as exc:
                if exc.code() not in RETRYABLE:
                    raise
                delay = min(self.max_backoff, self.backoff * 2 ** min(attempt, 30))
                if attempt >= self.max_retries:
                    if time.monotonic() + delay > deadline:
                        raise _RetriesExhausted(exc, attempt) from None
                    log.warning("asi server %s unreachable; retrying %s in %.1f s", self.address, what, delay)
                with self._counter_lock:
                    self.retries += 1
                attempt += 1
                time.sleep(delay * random.uniform(0.5, 1.5))

    def _fail(self, what: str, exc: Exception) -> SfvError:
        if isinstance(exc, _RetriesExhausted):
            return SfvError(f"asi server {self.address}: {what} failed after {exc.retries} retries "
                            f"({exc.error.code().name}: {exc.error.details()})")
        return SfvError(f"asi server {self.address}: {what} job {self.job_id!r}: {exc.code().name}: {exc.details()}")

    # --- API --------------------------------------------------------------------------------
    def wait_until_ready(self, timeout: float = 10.0) -> None:
        """Block until the channel connects; SfvError after `timeout` seconds."""
        try:
            grpc.channel_ready_future(self._channel).result(timeout=timeout)
        except grpc.FutureTimeoutError:
            raise SfvError(f"asi server {self.address}: not reachable within {timeout:g} s") from None

    def create_job(self, reference_states: np.ndarray, reference_phases: np.ndarray | None = None,
                   num_components: int = 10, phases: np.ndarray | None = None,
                   initial_means: np.ndarray | None = None, initial_stds: np.ndarray | None = None,
                   step_size: float | None = None, episodes_per_update: int | None = None,
                   max_step_fraction: float | None = None, min_std: float | None = None,
                   baseline: str = "component_mean", update_rule: str | None = None,
                   fall_weighting: float | None = None) -> JobInfo:
        """Create the job (or resume it: same dims -> its current version, created=False).

        reference_states (F, D): the clip's states; defaults follow the paper (means at the
        reference state nearest each phase, stds the per-dimension sample std).
        """
        reference_states = np.asarray(reference_states, np.float32)
        if reference_states.ndim != 2:
            raise SfvError(f"asi create_job {self.job_id!r}: reference_states must be (frames, state_dim), "
                           f"got shape {reference_states.shape}")
        request = asi_pb2.CreateJobRequest(
            job_id=self.job_id, state_dim=reference_states.shape[1], num_components=num_components,
            phases=[] if phases is None else np.asarray(phases, np.float64),
            initial_means_f64=_f64_bytes(initial_means),
            initial_stds_f64=_f64_bytes(initial_stds),
            reference_states_f32=np.ascontiguousarray(reference_states, "<f4").tobytes(),
            reference_phases=[] if reference_phases is None else np.asarray(reference_phases, np.float64),
            baseline=BASELINES[baseline])
        for name, value in (("step_size", step_size), ("episodes_per_update", episodes_per_update),
                            ("max_step_fraction", max_step_fraction), ("min_std", min_std), ("update_rule", update_rule),
                            ("fall_weighting", fall_weighting)):
            if value is not None:
                setattr(request, name, value)
        try:
            reply = self._call(self._stub.CreateJob, request)
        except (grpc.RpcError, _RetriesExhausted) as exc:
            raise self._fail("create", exc) from None
        self._last_version = reply.version
        return JobInfo(reply.version, reply.created, reply.state_dim, reply.num_components, reply.num_reference_frames)

    def sample(self, mode: str, count: int, seed: int | None = None, outage_s: float = 0.0) -> InitialStates:
        """`count` initial states drawn with mode 'asi', 'rsi' or 'fsi'; an unreachable server
        is retried for up to `outage_s` seconds beyond the usual retries."""
        if mode not in MODES:
            raise SfvError(f"asi sample: mode {mode!r} unknown; expected one of {sorted(MODES)}")
        request = asi_pb2.SampleRequest(job_id=self.job_id, mode=MODES[mode], count=count)
        if seed is not None:
            request.seed = seed
        try:
            reply = self._call(self._stub.SampleInitialStates, request, outage_s, "sample")
        except (grpc.RpcError, _RetriesExhausted) as exc:
            raise self._fail("sample", exc) from None
        self._last_version = reply.version
        states = np.frombuffer(reply.states_f32, "<f4").reshape(count, -1).copy()
        return InitialStates(states, np.asarray(reply.phases, np.float64), np.asarray(reply.components, np.int32),
                             reply.version)

    def report(self, initial_states: np.ndarray, components: np.ndarray, returns: np.ndarray,
               policy_version: int | None = None, fell: np.ndarray | None = None) -> int:
        """Report finished episodes; returns the distribution version (the last known one if dropped).

        `fell` (one bool per episode) feeds the server's per-component fall rates; None sends none.
        Rows with component -1 (RSI/FSI samples) carry no ASI gradient and are skipped here.
        """
        components = np.asarray(components, np.int32).reshape(-1)
        returns = np.asarray(returns, np.float64).reshape(-1)
        initial_states = np.asarray(initial_states, np.float32)
        fell = None if fell is None else np.asarray(fell, bool).reshape(-1)
        if initial_states.ndim != 2 or not initial_states.shape[0] == components.shape[0] == returns.shape[0] or \
                (fell is not None and fell.shape[0] != components.shape[0]):
            raise SfvError(f"asi report {self.job_id!r}: initial_states {initial_states.shape}, components "
                           f"{components.shape}, returns {returns.shape} and fell must have one row per episode")
        keep = components >= 0
        if not np.all(keep):
            initial_states, components, returns = initial_states[keep], components[keep], returns[keep]
            fell = None if fell is None else fell[keep]
        for start in range(0, components.shape[0], REPORT_CHUNK):
            stop = start + REPORT_CHUNK
            request = asi_pb2.ReportRequest(
                job_id=self.job_id, initial_states_f32=np.ascontiguousarray(initial_states[start:stop], "<f4").tobytes(),
                components=components[start:stop], returns=returns[start:stop],
                fell=[] if fell is None else fell[start:stop])
            if policy_version is not None:
                request.policy_version = policy_version
            try:
                self._last_version = self._call(self._stub.ReportEpisodes, request).version
            except _RetriesExhausted as exc:
                dropped = len(request.components)
                with self._counter_lock:
                    self.dropped_reports += dropped
                log.warning("asi server %s: dropped %d episodes after %d retries (%s)", self.address, dropped,
                            self.max_retries, exc.error.code().name)
            except grpc.RpcError as exc:
                raise self._fail("report", exc) from None
        return self._last_version

    def get_distribution(self) -> Distribution:
        try:
            reply = self._call(self._stub.GetDistribution, asi_pb2.GetDistributionRequest(job_id=self.job_id))
        except (grpc.RpcError, _RetriesExhausted) as exc:
            raise self._fail("get_distribution", exc) from None
        shape = (reply.num_components, reply.state_dim)
        self._last_version = reply.version
        k = reply.num_components
        # A server from before fall weighting sends neither: its draws are uniform and no rate is kept.
        weights = np.asarray(reply.component_weights, np.float64) if reply.component_weights else np.full(k, 1.0 / k)
        fall_rates = np.asarray(reply.fall_rates, np.float64) if reply.fall_rates else np.zeros(k)
        return Distribution(np.frombuffer(reply.means_f64, "<f8").reshape(shape).copy(),
                            np.frombuffer(reply.stds_f64, "<f8").reshape(shape).copy(),
                            np.asarray(reply.phases, np.float64), reply.version, reply.pending_episodes,
                            reply.update_rule or "gradient", weights, fall_rates)
