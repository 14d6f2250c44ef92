"""The ASI gRPC server: validates every request, samples and updates through a store.

Every request is checked before it touches the store (unknown job -> NOT_FOUND, wrong
sizes / non-finite numbers / out-of-range counts or components -> INVALID_ARGUMENT);
a store outage answers UNAVAILABLE (clients retry) and an unexpected fault INTERNAL,
and the server keeps serving either way. The standard grpc.health.v1 service reports
SERVING. Optional bearer-token auth (never logged) and TLS.
"""
from __future__ import annotations

import functools
import hmac
import logging
import re
from concurrent import futures
from dataclasses import dataclass, field
from pathlib import Path

import grpc
import numpy as np
from google.protobuf.message import DecodeError
from grpc_health.v1 import health, health_pb2, health_pb2_grpc

from actors.rollout.asi_client import BASELINES as BASELINE_ENUMS
from actors.rollout.asi_client import MAX_MESSAGE_BYTES
from learner.errors import SfvError
from proto import asi_pb2, asi_pb2_grpc
from services.asi.distribution import (
    UPDATE_RULES,
    InitialStateDistribution,
    UpdateConfig,
    evenly_spaced_phases,
    nearest_frames,
    reference_std,
)
from services.asi.fall_weights import component_weights, sampling_weights
from services.asi.store import ASIStore, EpisodeBatch, InMemoryStore, JobSpec, StoreUnavailable, TooManyJobs

log = logging.getLogger(__name__)

SERVICE_NAME = "sfv.asi.v1.InitialStateService"
TOKEN_ENV = "SFV_ASI_TOKEN"
JOB_ID_PATTERN = re.compile(r"[A-Za-z0-9._:-]{1,128}")
BASELINE_NAMES = {enum: name for name, enum in BASELINE_ENUMS.items()}  # the wire's enum -> UpdateConfig.baseline


@dataclass(frozen=True)
class ServerLimits:
    max_batch: int = field(default=8192, metadata={"help": "largest SampleInitialStates count"})
    max_report: int = field(default=65536, metadata={"help": "most episodes in one ReportEpisodes"})
    max_state_dim: int = field(default=4096, metadata={"help": "largest state_dim D"})
    max_components: int = field(default=1024, metadata={"help": "largest num_components k"})
    max_frames: int = field(default=200_000, metadata={"help": "most reference frames F"})
    max_episodes_per_update: int = field(default=100_000, metadata={"help": "largest episodes_per_update"})
    max_message_bytes: int = field(default=MAX_MESSAGE_BYTES, metadata={"help": "gRPC send/receive message limit (the client's)"})
    max_concurrent_rpcs: int = field(default=256, metadata={"help": "in-flight RPCs beyond this get RESOURCE_EXHAUSTED"})


class RequestError(Exception):
    """A request the server refuses; carries the gRPC status code."""

    def __init__(self, code: grpc.StatusCode, message: str):
        super().__init__(message)
        self.code = code


def _invalid(message: str) -> RequestError:
    return RequestError(grpc.StatusCode.INVALID_ARGUMENT, message)


def _handled(method):
    """Map refusals and faults to status codes so one bad request never takes the server down."""

    @functools.wraps(method)
    def wrapper(self, request, context):
        try:
            return method(self, request, context)
        except RequestError as exc:
            context.abort(exc.code, str(exc))
        except StoreUnavailable as exc:
            log.warning("%s: %s", method.__name__, exc)
            context.abort(grpc.StatusCode.UNAVAILABLE, str(exc))
        except TooManyJobs as exc:
            context.abort(grpc.StatusCode.RESOURCE_EXHAUSTED, str(exc))
        except Exception:  # noqa: BLE001 - a fault in one request must not stop the service
            log.exception("%s failed", method.__name__)
            context.abort(grpc.StatusCode.INTERNAL, f"{method.__name__}: internal error (see server log)")

    return wrapper


# --- decoding and checks -------------------------------------------------------------------
def _job_id(job_id: str) -> str:
    if not JOB_ID_PATTERN.fullmatch(job_id):
        raise _invalid("job_id must be 1-128 characters of [A-Za-z0-9._:-]")
    return job_id


def _array(blob: bytes, dtype: str, name: str) -> np.ndarray:
    itemsize = np.dtype(dtype).itemsize
    if len(blob) % itemsize:
        raise _invalid(f"{name}: {len(blob)} bytes is not a whole number of {itemsize}-byte values")
    values = np.frombuffer(blob, dtype)
    if not np.all(np.isfinite(values)):
        raise _invalid(f"{name}: contains NaN or infinity")
    return values


def _sized(values: np.ndarray, name: str, *sizes: int) -> np.ndarray:
    if values.size not in sizes:
        raise _invalid(f"{name}: {values.size} values, expected {' or '.join(map(str, sizes))}")
    return values


def _finite(values, name: str) -> np.ndarray:
    values = np.asarray(values, np.float64)
    if not np.all(np.isfinite(values)):
        raise _invalid(f"{name}: contains NaN or infinity")
    return values


def _phases(values, name: str) -> np.ndarray:
    values = _finite(values, name)
    if np.any((values < 0) | (values > 1)):
        raise _invalid(f"{name}: phases must lie in [0, 1]")
    return values


class InitialStateServicer(asi_pb2_grpc.InitialStateServiceServicer):
    def __init__(self, store: ASIStore, limits: ServerLimits = ServerLimits()):
        self.store = store
        self.limits = limits
        self._specs: dict[str, JobSpec] = {}  # immutable once created, so safe to cache

    def _spec(self, job_id: str) -> JobSpec:
        spec = self._specs.get(job_id)
        if spec is None:
            spec = self.store.get_spec(_job_id(job_id))
            if spec is None:
                raise RequestError(grpc.StatusCode.NOT_FOUND, f"job {job_id!r} not found (call CreateJob first)")
            self._specs[job_id] = spec
        return spec

    def _params(self, job_id: str):
        params = self.store.get_params(job_id)
        if params is None:
            raise RequestError(grpc.StatusCode.NOT_FOUND, f"job {job_id!r} not found (call CreateJob first)")
        return params

    # --- CreateJob ------------------------------------------------------------------------
    @_handled
    def CreateJob(self, request, context):
        spec, means, log_stds = self._parse_create(request)
        existing = self.store.get_spec(spec.job_id)
        if existing is not None and (existing.state_dim, existing.num_components) != (spec.state_dim, spec.num_components):
            raise RequestError(grpc.StatusCode.FAILED_PRECONDITION,
                               f"job {spec.job_id!r} exists with state_dim {existing.state_dim}, num_components "
                               f"{existing.num_components}; request has {spec.state_dim}, {spec.num_components}")
        stored, params, created = self.store.create_job(spec, means, log_stds)
        if (stored.state_dim, stored.num_components) != (spec.state_dim, spec.num_components):
            raise RequestError(grpc.StatusCode.FAILED_PRECONDITION, f"job {spec.job_id!r} exists with other dims")
        log.info("asi job %s: %s (D=%d, k=%d, F=%d, version %d)", spec.job_id, "created" if created else "resumed",
                 stored.state_dim, stored.num_components, stored.num_frames, params.version)
        return asi_pb2.JobInfo(job_id=stored.job_id, version=params.version, created=created,
                               state_dim=stored.state_dim, num_components=stored.num_components,
                               num_reference_frames=stored.num_frames)

    def _parse_create(self, request) -> tuple[JobSpec, np.ndarray, np.ndarray]:
        lim = self.limits
        job_id = _job_id(request.job_id)
        dim = request.state_dim
        if not 1 <= dim <= lim.max_state_dim:
            raise _invalid(f"state_dim {dim} outside [1, {lim.max_state_dim}]")
        k = request.num_components or 10
        if k > lim.max_components:
            raise _invalid(f"num_components {k} above {lim.max_components}")
        phases = evenly_spaced_phases(k) if not request.phases else _sized(_phases(request.phases, "phases"), "phases", k)

        reference = _array(request.reference_states_f32, "<f4", "reference_states_f32")
        if reference.size == 0 or reference.size % dim:
            raise _invalid(f"reference_states_f32: {reference.size} values is not a positive multiple of state_dim {dim}")
        reference = reference.reshape(-1, dim)
        frames = reference.shape[0]
        if frames > lim.max_frames:
            raise _invalid(f"reference_states_f32: {frames} frames above {lim.max_frames}")
        ref_phases = (np.linspace(0.0, 1.0, frames) if not request.reference_phases
                      else _sized(_phases(request.reference_phases, "reference_phases"), "reference_phases", frames))

        config = self._parse_config(request)
        means = (reference[nearest_frames(ref_phases, phases)].astype(np.float64) if not request.initial_means_f64
                 else _sized(_array(request.initial_means_f64, "<f8", "initial_means_f64"),
                             "initial_means_f64", k * dim).reshape(k, dim))
        if not request.initial_stds_f64:
            stds = reference_std(reference.astype(np.float64), config.min_std)
        else:
            stds = _sized(_array(request.initial_stds_f64, "<f8", "initial_stds_f64"), "initial_stds_f64", dim, k * dim)
            if np.any(stds <= 0):
                raise _invalid("initial_stds_f64: standard deviations must be > 0")
        # Stds below the floor are raised to it, exactly as after every update.
        stds = np.maximum(np.broadcast_to(stds.reshape(-1, dim), (k, dim)), config.min_std)
        spec = JobSpec(job_id, config, phases, np.ascontiguousarray(reference), ref_phases)
        return spec, np.ascontiguousarray(means, np.float64), np.log(stds)

    def _parse_config(self, request) -> UpdateConfig:
        defaults = UpdateConfig()
        step_size = request.step_size if request.HasField("step_size") else defaults.step_size
        if not (np.isfinite(step_size) and step_size >= 0):
            raise _invalid(f"step_size {step_size} must be finite and >= 0")
        per_update = request.episodes_per_update if request.HasField("episodes_per_update") else defaults.episodes_per_update
        if not 1 <= per_update <= self.limits.max_episodes_per_update:
            raise _invalid(f"episodes_per_update {per_update} outside [1, {self.limits.max_episodes_per_update}]")
        fraction = request.max_step_fraction if request.HasField("max_step_fraction") else defaults.max_step_fraction
        if not (np.isfinite(fraction) and fraction >= 0):
            raise _invalid(f"max_step_fraction {fraction} must be finite and >= 0")
        min_std = request.min_std if request.HasField("min_std") else defaults.min_std
        if not (np.isfinite(min_std) and min_std > 0):
            raise _invalid(f"min_std {min_std} must be finite and > 0")
        baseline = BASELINE_NAMES.get(request.baseline)
        if baseline is None:
            raise _invalid(f"baseline {request.baseline} unknown")
        rule = request.update_rule if request.HasField("update_rule") else defaults.rule
        if rule not in UPDATE_RULES:
            raise _invalid(f"update_rule {rule[:40]!r} unknown; expected one of {', '.join(UPDATE_RULES)}")
        beta = request.fall_weighting if request.HasField("fall_weighting") else defaults.fall_weighting
        if not 0.0 <= beta <= 1.0:  # NaN fails too
            raise _invalid(f"fall_weighting {beta} must lie in [0, 1] (0: uniform components)")
        return UpdateConfig(float(step_size), int(per_update), float(fraction), float(min_std), baseline, rule, float(beta))

    # --- SampleInitialStates -----------------------------------------------------------------
    @_handled
    def SampleInitialStates(self, request, context):
        spec = self._spec(request.job_id)
        count = request.count
        if not 1 <= count <= self.limits.max_batch:
            raise _invalid(f"count {count} outside [1, {self.limits.max_batch}]")
        if request.mode not in (asi_pb2.ASI, asi_pb2.RSI, asi_pb2.FSI):
            raise _invalid(f"mode {request.mode} unknown")
        rng = np.random.default_rng(request.seed if request.HasField("seed") else None)
        params = self._params(spec.job_id)
        if request.mode == asi_pb2.ASI:
            weights = sampling_weights(params.fall_rates(), spec.config.fall_weighting)
            states, components = InitialStateDistribution(spec.phases, params.means, params.log_stds).sample(
                rng, count, weights)
            phases = spec.phases[components]
            frames = np.full(count, -1, np.int32)
        else:
            frames = (rng.integers(spec.num_frames, size=count) if request.mode == asi_pb2.RSI
                      else np.zeros(count, np.int64)).astype(np.int32)
            states = spec.reference_states[frames]
            phases = spec.reference_phases[frames]
            components = np.full(count, -1, np.int32)
        return asi_pb2.SampleReply(states_f32=np.ascontiguousarray(states, "<f4").tobytes(), phases=phases,
                                   components=components, frames=frames, version=params.version)

    # --- ReportEpisodes ----------------------------------------------------------------------
    @_handled
    def ReportEpisodes(self, request, context):
        spec = self._spec(request.job_id)
        n = len(request.components)
        if not 1 <= n <= self.limits.max_report:
            raise _invalid(f"{n} episodes; a report holds 1 to {self.limits.max_report}")
        returns = _sized(_finite(request.returns, "returns"), "returns", n)
        states = _sized(_array(request.initial_states_f32, "<f4", "initial_states_f32"),
                        "initial_states_f32", n * spec.state_dim).reshape(n, spec.state_dim)
        components = np.asarray(request.components, np.int32)
        if np.any((components < 0) | (components >= spec.num_components)):
            raise _invalid(f"components must lie in [0, {spec.num_components}) (RSI/FSI samples carry no component)")
        policy_version = request.policy_version if request.HasField("policy_version") else None
        fell = self._fell(request, n)
        outcome = self.store.report(spec, EpisodeBatch(states, components, returns), policy_version, fell)
        if outcome.updated:
            log.info("asi job %s: now version %d, %d episodes pending", spec.job_id, outcome.version,
                     outcome.pending_episodes)
        return asi_pb2.ReportReply(accepted=n, version=outcome.version, updated=outcome.updated,
                                   pending_episodes=outcome.pending_episodes)

    @staticmethod
    def _fell(request, n: int) -> np.ndarray | None:
        """The episodes' fall flags; None when the client sent none (an older client)."""
        if not request.fell:
            return None
        if len(request.fell) != n:
            raise _invalid(f"fell: {len(request.fell)} flags for {n} episodes (one per episode, or none)")
        return np.asarray(request.fell, bool)

    # --- GetDistribution ---------------------------------------------------------------------
    @_handled
    def GetDistribution(self, request, context):
        spec = self._spec(request.job_id)
        params = self._params(spec.job_id)
        config = spec.config
        reply = asi_pb2.Distribution(
            means_f64=np.ascontiguousarray(params.means, "<f8").tobytes(),
            stds_f64=np.ascontiguousarray(np.exp(params.log_stds), "<f8").tobytes(),
            phases=spec.phases, version=params.version, pending_episodes=params.pending_episodes,
            state_dim=spec.state_dim, num_components=spec.num_components, step_size=config.step_size,
            episodes_per_update=config.episodes_per_update, max_step_fraction=config.max_step_fraction,
            min_std=config.min_std, baseline=BASELINE_ENUMS[config.baseline], update_rule=config.rule,
            component_weights=component_weights(params.fall_rates(), config.fall_weighting),
            fall_rates=params.fall_rates(), fall_weighting=config.fall_weighting)
        if params.policy_version is not None:
            reply.policy_version = params.policy_version
        return reply


def _decoding(handler, request_type):
    """Parse the request bytes ourselves: garbage gets INVALID_ARGUMENT, not a logged traceback."""

    def parse_then_handle(request_bytes: bytes, context):
        try:
            request = request_type.FromString(request_bytes)
        except DecodeError:
            context.abort(grpc.StatusCode.INVALID_ARGUMENT,
                          f"request is not a valid {request_type.DESCRIPTOR.full_name} message")
        return handler(request, context)

    return parse_then_handle


def service_handler(servicer: InitialStateServicer) -> grpc.GenericRpcHandler:
    """The InitialStateService methods, with request parsing inside the handler."""
    methods = {}
    for method in asi_pb2.DESCRIPTOR.services_by_name["InitialStateService"].methods:
        request_type = getattr(asi_pb2, method.input_type.name)
        reply_type = getattr(asi_pb2, method.output_type.name)
        methods[method.name] = grpc.unary_unary_rpc_method_handler(
            _decoding(getattr(servicer, method.name), request_type), request_deserializer=None,
            response_serializer=reply_type.SerializeToString)
    return grpc.method_handlers_generic_handler(SERVICE_NAME, methods)


# --- auth ------------------------------------------------------------------------------------
def _deny(request, context):
    context.abort(grpc.StatusCode.UNAUTHENTICATED, "missing or wrong bearer token (metadata 'authorization')")


class BearerTokenAuth(grpc.ServerInterceptor):
    """Requires `authorization: Bearer <token>` on every ASI call; health checks stay open for probes."""

    _DENY = grpc.unary_unary_rpc_method_handler(_deny)

    def __init__(self, token: str):
        self._expected = f"Bearer {token}".encode()

    def intercept_service(self, continuation, handler_call_details):
        if handler_call_details.method.startswith("/grpc.health.v1.Health/"):
            return continuation(handler_call_details)
        for key, value in handler_call_details.invocation_metadata or ():
            if key == "authorization":
                given = value.encode() if isinstance(value, str) else value
                if hmac.compare_digest(given, self._expected):
                    return continuation(handler_call_details)
        return self._DENY


# --- serving ---------------------------------------------------------------------------------
class RunningServer:
    """A started gRPC server plus its health service; stop() flips health to NOT_SERVING first."""

    def __init__(self, grpc_server: grpc.Server, health_servicer: health.HealthServicer, address: str):
        self.grpc_server = grpc_server
        self.health = health_servicer
        self.address = address

    def stop(self, grace: float | None = 2.0):
        self.health.enter_graceful_shutdown()
        return self.grpc_server.stop(grace)

    def wait_for_termination(self, timeout: float | None = None) -> bool:
        return self.grpc_server.wait_for_termination(timeout)


def _read_file(path: str | Path, what: str) -> bytes:
    try:
        return Path(path).read_bytes()
    except OSError as exc:
        raise SfvError(f"{path}: cannot read {what} ({exc.strerror})") from None


def serve(port: int, store: ASIStore | None = None, host: str = "127.0.0.1", token: str | None = None,
          tls_cert: str | Path | None = None, tls_key: str | Path | None = None, max_workers: int = 8,
          limits: ServerLimits = ServerLimits()) -> tuple[RunningServer, int]:
    """Start the ASI server on host:port (port 0 picks a free one). Returns (server, bound port)."""
    if (tls_cert is None) != (tls_key is None):
        raise SfvError("asi server: --tls-cert and --tls-key go together")
    store = InMemoryStore() if store is None else store
    options = [("grpc.max_receive_message_length", limits.max_message_bytes),
               ("grpc.max_send_message_length", limits.max_message_bytes),
               ("grpc.so_reuseport", 0)]
    interceptors = [BearerTokenAuth(token)] if token else []
    server = grpc.server(futures.ThreadPoolExecutor(max_workers=max_workers, thread_name_prefix="asi"),
                         interceptors=interceptors, options=options,
                         maximum_concurrent_rpcs=limits.max_concurrent_rpcs)
    server.add_generic_rpc_handlers((service_handler(InitialStateServicer(store, limits)),))
    health_servicer = health.HealthServicer()
    health_pb2_grpc.add_HealthServicer_to_server(health_servicer, server)
    target = f"[{host}]:{port}" if ":" in host else f"{host}:{port}"
    try:
        if tls_cert is not None:
            credentials = grpc.ssl_server_credentials([(_read_file(tls_key, "TLS key"), _read_file(tls_cert, "TLS certificate"))])
            bound = server.add_secure_port(target, credentials)
        else:
            bound = server.add_insecure_port(target)
    except RuntimeError as exc:
        raise SfvError(f"asi server: cannot bind {target} ({exc})") from None
    if not bound:
        raise SfvError(f"asi server: cannot bind {target}")
    server.start()
    for name in ("", SERVICE_NAME):
        health_servicer.set(name, health_pb2.HealthCheckResponse.SERVING)
    address = f"[{host}]:{bound}" if ":" in host else f"{host}:{bound}"
    log.info("asi server listening on %s (%s%s)", address, "tls" if tls_cert else "plaintext",
             ", token auth" if token else "")
    return RunningServer(server, health_servicer, address), bound


class EmbeddedASIServer:
    """The ASI server inside this process on a free loopback port: nothing to start for local runs.

        with EmbeddedASIServer() as asi:
            client = ASIClient(asi.address, job_id="walk")
    """

    def __init__(self, store: ASIStore | None = None, token: str | None = None, max_workers: int = 4):
        self.store = InMemoryStore() if store is None else store
        self.token = token
        self.max_workers = max_workers
        self._server: RunningServer | None = None
        self.port = 0

    @property
    def address(self) -> str:
        if self._server is None:
            raise SfvError("embedded asi server: not started")
        return self._server.address

    def start(self) -> "EmbeddedASIServer":
        if self._server is None:
            self._server, self.port = serve(0, self.store, token=self.token, max_workers=self.max_workers)
        return self

    def stop(self, grace: float | None = 1.0) -> None:
        if self._server is not None:
            self._server.stop(grace).wait()
            self._server = None

    def __enter__(self) -> "EmbeddedASIServer":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
