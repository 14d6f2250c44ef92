"""Fuzz the ASI server (in its own process): every reply is a valid message or a proper error code.

1500 requests: garbage bytes and byte-mutated valid requests through a raw channel, plus
structured requests with huge counts, NaN/inf/huge numbers, wrong sizes, unknown jobs and
out-of-range enums. Health must stay SERVING and the server's RSS must stay bounded.
"""
import grpc
import numpy as np
import pytest
from grpc_health.v1 import health_pb2, health_pb2_grpc

from proto import asi_pb2
from tests.asi_helpers import D, K, ServerProcess, create_request, report_request

pytestmark = pytest.mark.integration

SERVICE = "/sfv.asi.v1.InitialStateService/"
REPLY_TYPES = {"CreateJob": asi_pb2.JobInfo, "SampleInitialStates": asi_pb2.SampleReply,
               "ReportEpisodes": asi_pb2.ReportReply, "GetDistribution": asi_pb2.Distribution}
REFUSALS = {grpc.StatusCode.INVALID_ARGUMENT, grpc.StatusCode.NOT_FOUND, grpc.StatusCode.FAILED_PRECONDITION}
REQUESTS = 1500
RSS_GROWTH_LIMIT = 64 * 1024 * 1024


def odd_numbers(rng, size):
    pool = np.array([np.nan, np.inf, -np.inf, 3.4e38, -3.4e38, 1e-45, 0.0, 1.0])
    values = rng.normal(size=size)
    mask = rng.random(size) < 0.3
    values[mask] = rng.choice(pool, size=int(mask.sum()))
    return values


def random_job_id(rng):
    return str(rng.choice(["fuzz", "ghost", "", "bad id", "fuzz-1", "fuzz-2", "ü" * 3, "x" * 200]))


def structured_request(rng):
    """(method, request message) built field by field with hostile values."""
    kind = rng.integers(4)
    job = random_job_id(rng)
    if kind == 0:
        count = int(rng.choice([0, 1, 7, 8192, 8193, 100_000, 2**32 - 1]))
        request = asi_pb2.SampleRequest(job_id=job, count=count, mode=int(rng.integers(-1, 5)))
        if rng.random() < 0.5:
            request.seed = int(rng.integers(2**63))
        return "SampleInitialStates", request
    if kind == 1:
        n = int(rng.choice([0, 1, 3, 50, 200]))
        rows = n + int(rng.choice([0, 0, 0, -1, 1]))
        states = odd_numbers(rng, max(rows, 0) * D).astype("<f4") if rng.random() < 0.5 else \
            rng.normal(size=max(rows, 0) * D).astype("<f4")
        returns = odd_numbers(rng, n) if rng.random() < 0.3 else rng.normal(size=n)
        components = rng.integers(-2, K + 2, size=n) if rng.random() < 0.3 else rng.integers(K, size=n)
        return "ReportEpisodes", asi_pb2.ReportRequest(job_id=job, initial_states_f32=states.tobytes(),
                                                       components=components, returns=returns)
    if kind == 2:
        dim = int(rng.choice([0, 1, D, D + 1, 5000]))
        frames = int(rng.choice([0, 1, 4]))
        fields = dict(job_id=str(rng.choice(["fuzz", "fuzz-1", "fuzz-2", job])), state_dim=dim,
                      num_components=int(rng.choice([0, 1, K, 2000])),
                      reference_states_f32=odd_numbers(rng, frames * dim + int(rng.integers(0, 2))).astype("<f4").tobytes())
        if rng.random() < 0.3:
            fields["phases"] = odd_numbers(rng, int(rng.integers(0, 5)))
        if rng.random() < 0.3:
            fields["initial_stds_f64"] = odd_numbers(rng, dim).tobytes()
        if rng.random() < 0.3:
            fields["step_size"] = float(odd_numbers(rng, 1)[0])
        if rng.random() < 0.3:
            fields["episodes_per_update"] = int(rng.choice([0, 1, 10**9]))
        return "CreateJob", asi_pb2.CreateJobRequest(**fields)
    return "GetDistribution", asi_pb2.GetDistributionRequest(job_id=job)


def mutated_bytes(rng):
    """A valid serialized request with bytes flipped, cut or appended, or plain noise."""
    method = str(rng.choice(list(REPLY_TYPES)))
    valid = {"CreateJob": create_request("fuzz"), "SampleInitialStates": asi_pb2.SampleRequest(job_id="fuzz", count=4),
             "ReportEpisodes": report_request("fuzz"), "GetDistribution": asi_pb2.GetDistributionRequest(job_id="fuzz")}
    blob = bytearray(valid[method].SerializeToString())
    choice = rng.integers(4)
    if choice == 0:
        blob = bytearray(rng.bytes(int(rng.integers(0, 300))))
    elif choice == 1 and blob:
        for i in rng.integers(len(blob), size=int(rng.integers(1, 8))):
            blob[i] = int(rng.integers(256))
    elif choice == 2:
        blob = blob[: int(rng.integers(len(blob) + 1))]
    else:
        blob += rng.bytes(int(rng.integers(1, 64)))
    return method, bytes(blob)


def check_reply(method, reply, request, typed):
    """A successful reply must be a well-formed message consistent with the request and the job."""
    if method == "SampleInitialStates" and request is not None:
        job = typed["GetDistribution"](asi_pb2.GetDistributionRequest(job_id=request.job_id), timeout=5)
        assert len(reply.states_f32) == request.count * job.state_dim * 4
        assert len(reply.phases) == len(reply.components) == len(reply.frames) == request.count
        assert np.all(np.isfinite(np.frombuffer(reply.states_f32, "<f4")))
    if method == "GetDistribution":
        means = np.frombuffer(reply.means_f64, "<f8")
        stds = np.frombuffer(reply.stds_f64, "<f8")
        assert means.size == stds.size == reply.num_components * reply.state_dim
        assert np.all(np.isfinite(means)) and np.all(stds > 0)


def test_fuzzed_requests_get_valid_replies_or_error_codes(tmp_path):
    server = ServerProcess(tmp_path / "asi.log", "--port", "0", "--max-workers", "4")
    try:
        address = server.wait_listening()
        channel = grpc.insecure_channel(address)
        raw = {m: channel.unary_unary(SERVICE + m, request_serializer=None, response_deserializer=None)
               for m in REPLY_TYPES}
        typed = {m: channel.unary_unary(SERVICE + m, request_serializer=lambda r: r.SerializeToString(),
                                        response_deserializer=REPLY_TYPES[m].FromString) for m in REPLY_TYPES}
        assert typed["CreateJob"](create_request("fuzz", episodes_per_update=50), timeout=5).created
        rng = np.random.default_rng(20180501)
        outcomes = {"ok": 0, "refused": 0, "undecodable": 0}
        rss_after_warmup = None
        for i in range(REQUESTS):
            if i == 200:
                rss_after_warmup = server.rss_bytes()
            is_raw = rng.random() < 0.4
            method, request = mutated_bytes(rng) if is_raw else structured_request(rng)
            try:
                reply = (raw if is_raw else typed)[method](request, timeout=10)
            except grpc.RpcError as exc:
                code, details = exc.code(), exc.details() or ""
                if code in REFUSALS:
                    outcomes["refused" if "is not a valid" not in details else "undecodable"] += 1
                else:
                    pytest.fail(f"request {i} {method}: unexpected {code.name}: {details}")
            else:
                outcomes["ok"] += 1
                check_reply(method, REPLY_TYPES[method].FromString(reply) if is_raw else reply,
                            None if is_raw else request, typed)
        health = health_pb2_grpc.HealthStub(channel).Check(health_pb2.HealthCheckRequest(), timeout=5)
        assert health.status == health_pb2.HealthCheckResponse.SERVING
        assert typed["SampleInitialStates"](asi_pb2.SampleRequest(job_id="fuzz", count=8), timeout=5).version >= 0
        growth = server.rss_bytes() - rss_after_warmup
        assert growth < RSS_GROWTH_LIMIT, f"server RSS grew {growth / 2**20:.1f} MiB during the fuzz"
        assert min(outcomes.values()) > 0, outcomes  # every kind of outcome was exercised
        channel.close()
    finally:
        assert server.stop() == 0
    assert "Traceback" not in server.log_text()
