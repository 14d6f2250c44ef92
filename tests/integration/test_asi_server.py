"""The ASI gRPC server end to end: real server, real channel (and real Redis where named)."""
import subprocess

import grpc
import numpy as np
import pytest
from grpc_health.v1 import health_pb2, health_pb2_grpc

from actors.rollout.asi_client import ASIClient
from learner.errors import SfvError
from proto import asi_pb2, asi_pb2_grpc
from services.asi.distribution import InitialStateDistribution, UpdateConfig
from services.asi.server import SERVICE_NAME, EmbeddedASIServer, serve
from services.asi.store import InMemoryStore
from tests.asi_helpers import FRAMES, D, K, create_request, reference_clip, report_request

pytestmark = pytest.mark.integration
INVALID, NOT_FOUND = grpc.StatusCode.INVALID_ARGUMENT, grpc.StatusCode.NOT_FOUND


@pytest.fixture
def server():
    running, port = serve(0, InMemoryStore())
    yield running
    running.stop(None).wait()


@pytest.fixture
def stub(server):
    with grpc.insecure_channel(server.address) as channel:
        yield asi_pb2_grpc.InitialStateServiceStub(channel)


def health_status(address: str, service: str = "") -> int:
    with grpc.insecure_channel(address) as channel:
        return health_pb2_grpc.HealthStub(channel).Check(health_pb2.HealthCheckRequest(service=service), timeout=5).status


def test_create_job_is_idempotent_and_rejects_other_dims(stub):
    first = stub.CreateJob(create_request(), timeout=5)
    assert (first.created, first.version, first.state_dim, first.num_components, first.num_reference_frames) == \
        (True, 0, D, K, FRAMES)
    assert stub.CreateJob(create_request(), timeout=5).created is False
    states, _ = reference_clip()
    with pytest.raises(grpc.RpcError) as err:
        stub.CreateJob(create_request(state_dim=D - 1, reference_states_f32=states[:, :-1].tobytes()), timeout=5)
    assert err.value.code() == grpc.StatusCode.FAILED_PRECONDITION
    with pytest.raises(grpc.RpcError) as err:
        stub.CreateJob(create_request(num_components=K + 1), timeout=5)
    assert err.value.code() == grpc.StatusCode.FAILED_PRECONDITION


def test_default_parameters_follow_the_paper(server):
    states, phases = reference_clip()
    client = ASIClient(server.address, "walk")
    client.create_job(states, phases, num_components=5)  # phases i/5 -> frames 0, 3, 6, 9, 12 (frame f at f/15)
    dist = client.get_distribution()
    np.testing.assert_allclose(dist.phases, [0, 0.2, 0.4, 0.6, 0.8])
    np.testing.assert_array_equal(dist.means, states[[0, 3, 6, 9, 12]].astype(np.float64))
    expected_std = np.maximum(states.astype(np.float64).std(axis=0, ddof=1), 1e-3)
    np.testing.assert_allclose(dist.stds, np.broadcast_to(expected_std, (5, D)), rtol=1e-12)
    client.close()


def test_asi_samples_follow_the_distribution(server):
    states, phases = reference_clip()
    means = np.arange(K * D, dtype=np.float64).reshape(K, D)
    stds = np.linspace(0.1, 2.0, K * D).reshape(K, D)
    client = ASIClient(server.address, "stats")
    client.create_job(states, phases, num_components=K, initial_means=means, initial_stds=stds)
    draws = [client.sample("asi", 8192, seed=s) for s in range(6)]
    sampled = np.concatenate([d.states for d in draws]).astype(np.float64)
    components = np.concatenate([d.components for d in draws])
    assert draws[0].states.shape == (8192, D) and draws[0].states.dtype == np.float32
    np.testing.assert_array_equal(np.concatenate([d.phases for d in draws]), np.array([0, 1 / 3, 2 / 3])[components])
    for c in range(K):
        rows = sampled[components == c]
        assert abs(len(rows) - len(sampled) / K) < 5 * np.sqrt(len(sampled) / K)
        assert np.all(np.abs(rows.mean(axis=0) - means[c]) < 5 * stds[c] / np.sqrt(len(rows)))
        np.testing.assert_allclose(rows.std(axis=0), stds[c], rtol=0.05)
    again = client.sample("asi", 8192, seed=0)
    np.testing.assert_array_equal(again.states, draws[0].states)  # a seed makes the draw reproducible
    assert not np.array_equal(client.sample("asi", 16).states, client.sample("asi", 16).states)
    client.close()


def test_fsi_returns_frame_zero_and_rsi_covers_all_frames(stub):
    states, phases = reference_clip()
    stub.CreateJob(create_request(), timeout=5)
    fsi = stub.SampleInitialStates(asi_pb2.SampleRequest(job_id="job", mode=asi_pb2.FSI, count=50), timeout=5)
    fsi_states = np.frombuffer(fsi.states_f32, "<f4").reshape(50, D)
    assert np.all(fsi_states == states[0]) and set(fsi.frames) == {0} and set(fsi.components) == {-1}
    assert set(fsi.phases) == {0.0}
    rsi = stub.SampleInitialStates(asi_pb2.SampleRequest(job_id="job", mode=asi_pb2.RSI, count=2000), timeout=5)
    frames = np.asarray(rsi.frames)
    rsi_states = np.frombuffer(rsi.states_f32, "<f4").reshape(2000, D)
    np.testing.assert_array_equal(rsi_states, states[frames])
    np.testing.assert_array_equal(rsi.phases, phases[frames])
    counts = np.bincount(frames, minlength=FRAMES)
    assert counts.size == FRAMES and np.all(counts > 2000 / FRAMES / 2)  # every frame, roughly uniformly
    assert set(rsi.components) == {-1}


def test_version_advances_after_episodes_per_update_and_step_matches_numpy(server):
    states, phases = reference_clip()
    client = ASIClient(server.address, "learn")
    client.create_job(states, phases, num_components=K, episodes_per_update=50, step_size=0.01)
    start = client.get_distribution()
    draw = client.sample("asi", 80, seed=3)
    returns = -np.abs(draw.states[:, 1]).astype(np.float64)  # prefer states near 0 in dim 1
    assert client.report(draw.states[:30], draw.components[:30], returns[:30]) == 0
    assert client.get_distribution().pending_episodes == 30
    assert client.report(draw.states[30:], draw.components[30:], returns[30:]) == 1
    after = client.get_distribution()
    assert (after.version, after.pending_episodes) == (1, 30)
    expected = InitialStateDistribution(start.phases, start.means, np.log(start.stds)).apply_update(
        draw.states[:50], draw.components[:50], returns[:50], UpdateConfig(step_size=0.01, episodes_per_update=50))
    np.testing.assert_allclose(after.means, expected.means, rtol=1e-12)
    np.testing.assert_allclose(after.stds, expected.stds, rtol=1e-12)
    assert not np.allclose(after.means, start.means)
    assert client.sample("asi", 1).version == 1
    client.close()


def bad_requests():
    states, _ = reference_clip()
    nan_states = states.copy()
    nan_states[3, 2] = np.nan
    create = [
        dict(job_id=""), dict(job_id="has space"), dict(job_id="x" * 129), dict(state_dim=0), dict(state_dim=100_000),
        dict(num_components=5000), dict(reference_states_f32=b"abc"), dict(reference_states_f32=b""),
        dict(reference_states_f32=states[:, :-1].tobytes()), dict(reference_states_f32=nan_states.tobytes()),
        dict(reference_phases=[0.5]), dict(reference_phases=np.linspace(0, 2, FRAMES)),
        dict(phases=[0.0, 0.5]), dict(phases=[0.0, 0.5, float("nan")]),
        dict(initial_means_f64=np.zeros(K * D - 1).tobytes()),
        dict(initial_means_f64=np.full(K * D, np.inf).tobytes()),
        dict(initial_stds_f64=(-np.ones(D)).tobytes()), dict(initial_stds_f64=np.ones(D + 1).tobytes()),
        dict(step_size=float("nan")), dict(step_size=-1.0), dict(episodes_per_update=0),
        dict(episodes_per_update=10**9), dict(max_step_fraction=-0.1), dict(min_std=0.0), dict(baseline=7),
        dict(update_rule="adam"), dict(fall_weighting=-0.1), dict(fall_weighting=1.5),
        dict(fall_weighting=float("nan")),
    ]
    cases = [("CreateJob", create_request(**{"job_id": "bad", **c}), INVALID) for c in create]
    cases += [
        ("SampleInitialStates", asi_pb2.SampleRequest(job_id="ghost", count=1), NOT_FOUND),
        ("SampleInitialStates", asi_pb2.SampleRequest(job_id="job", count=0), INVALID),
        ("SampleInitialStates", asi_pb2.SampleRequest(job_id="job", count=8193), INVALID),
        ("SampleInitialStates", asi_pb2.SampleRequest(job_id="job", count=2**32 - 1), INVALID),
        ("SampleInitialStates", asi_pb2.SampleRequest(job_id="job", count=1, mode=9), INVALID),
        ("SampleInitialStates", asi_pb2.SampleRequest(job_id="bad id!", count=1), INVALID),
        ("ReportEpisodes", report_request(job_id="ghost"), NOT_FOUND),
        ("ReportEpisodes", report_request(n=0), INVALID),
        ("ReportEpisodes", report_request(initial_states_f32=b"\0" * (4 * D * 4 - 4)), INVALID),
        ("ReportEpisodes", report_request(initial_states_f32=np.full(4 * D, np.nan, "<f4").tobytes()), INVALID),
        ("ReportEpisodes", report_request(components=[0, 1, -1, 2]), INVALID),
        ("ReportEpisodes", report_request(components=[0, 1, K, 2]), INVALID),
        ("ReportEpisodes", report_request(returns=[0.0, 1.0, float("nan"), 2.0]), INVALID),
        ("ReportEpisodes", report_request(returns=[0.0, 1.0, float("inf"), 2.0]), INVALID),
        ("ReportEpisodes", report_request(returns=[0.0, 1.0]), INVALID),
        ("ReportEpisodes", report_request(fell=[True, False]), INVALID),
        ("GetDistribution", asi_pb2.GetDistributionRequest(job_id="ghost"), NOT_FOUND),
        ("GetDistribution", asi_pb2.GetDistributionRequest(job_id=""), INVALID),
    ]
    return cases


def test_every_bad_request_gets_its_code_and_the_server_keeps_serving(server, stub):
    stub.CreateJob(create_request(), timeout=5)
    for method, request, code in bad_requests():
        with pytest.raises(grpc.RpcError) as err:
            getattr(stub, method)(request, timeout=5)
        assert err.value.code() == code, (method, request, err.value.details())
        assert err.value.details()  # a message saying what is wrong
    assert health_status(server.address) == health_pb2.HealthCheckResponse.SERVING
    assert health_status(server.address, SERVICE_NAME) == health_pb2.HealthCheckResponse.SERVING
    with pytest.raises(grpc.RpcError):
        stub.GetDistribution(asi_pb2.GetDistributionRequest(job_id="bad"), timeout=5)  # no bad job was created
    assert stub.GetDistribution(asi_pb2.GetDistributionRequest(job_id="job"), timeout=5).pending_episodes == 0
    assert stub.ReportEpisodes(report_request(), timeout=5).accepted == 4


def test_token_auth_rejects_missing_and_wrong_tokens():
    running, port = serve(0, InMemoryStore(), token="tok-123")
    try:
        states, phases = reference_clip()
        for token in (None, "wrong"):
            with pytest.raises(SfvError, match="UNAUTHENTICATED"), ASIClient(running.address, "j", token=token) as c:
                c.create_job(states, phases)
        with ASIClient(running.address, "j", token="tok-123") as client:
            assert client.create_job(states, phases).created
            assert client.sample("rsi", 3).states.shape == (3, D)
        assert health_status(running.address) == health_pb2.HealthCheckResponse.SERVING  # probes need no token
    finally:
        running.stop(None).wait()


def test_tls_serves_trusted_clients_only(tmp_path):
    cert, key = tmp_path / "cert.pem", tmp_path / "key.pem"
    subprocess.run(["openssl", "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
                    "-days", "1", "-subj", "/CN=localhost", "-addext", "subjectAltName=IP:127.0.0.1,DNS:localhost",
                    "-keyout", str(key), "-out", str(cert)], check=True, capture_output=True)
    running, port = serve(0, InMemoryStore(), tls_cert=cert, tls_key=key)
    try:
        states, phases = reference_clip()
        with ASIClient(running.address, "tls", tls_root_cert=cert) as client:
            assert client.create_job(states, phases).created
        with pytest.raises(SfvError), ASIClient(running.address, "tls", max_retries=0, timeout=2) as plain:
            plain.sample("fsi", 1)
    finally:
        running.stop(None).wait()


def test_restarted_server_with_redis_store_returns_identical_parameters_and_version(redis_url):
    from services.asi.redis_store import RedisStore

    states, phases = reference_clip()
    running, port = serve(0, RedisStore(redis_url))
    client = ASIClient(running.address, "resume")
    client.create_job(states, phases, num_components=K, episodes_per_update=40)
    draw = client.sample("asi", 100, seed=1)
    client.report(draw.states, draw.components, draw.states[:, 0].astype(np.float64))
    before = client.get_distribution()
    client.close()
    running.stop(None).wait()

    restarted, port = serve(0, RedisStore(redis_url))
    try:
        with ASIClient(restarted.address, "resume") as again:
            info = again.create_job(states, phases, num_components=K, episodes_per_update=40)
            assert (info.created, info.version) == (False, 2)
            after = again.get_distribution()
            assert (after.version, after.pending_episodes) == (before.version, before.pending_episodes) == (2, 20)
            np.testing.assert_array_equal(after.means, before.means)
            np.testing.assert_array_equal(after.stds, before.stds)
            assert again.report(draw.states[:20], draw.components[:20], np.zeros(20)) == 3
    finally:
        restarted.stop(None).wait()


def test_embedded_server_needs_nothing_started():
    states, phases = reference_clip()
    with EmbeddedASIServer() as embedded:
        assert embedded.address.startswith("127.0.0.1:")
        with ASIClient(embedded.address, "local") as client:
            client.create_job(states, phases)
            np.testing.assert_array_equal(client.sample("fsi", 2).states, states[[0, 0]])
    with pytest.raises(SfvError):
        embedded.address


def test_the_natural_rule_steps_in_units_of_sigma(server):
    """update_rule "natural" goes over the wire, is reported back, and the server's step is the
    numpy one: each mean moves by about alpha x sigma x corr(z, A) where the returns favour a side."""
    states, phases = reference_clip()
    client = ASIClient(server.address, "natural")
    client.create_job(states, phases, num_components=K, episodes_per_update=400, step_size=0.2, update_rule="natural")
    start = client.get_distribution()
    assert start.update_rule == "natural"
    draw = client.sample("asi", 400, seed=5)
    returns = draw.states[:, 1].astype(np.float64)  # higher is better along dimension 1
    assert client.report(draw.states, draw.components, returns) == 1
    after = client.get_distribution()
    expected = InitialStateDistribution(start.phases, start.means, np.log(start.stds)).apply_update(
        draw.states, draw.components, returns, UpdateConfig(step_size=0.2, episodes_per_update=400, rule="natural"))
    np.testing.assert_allclose(after.means, expected.means, rtol=1e-12)
    moved = (after.means - start.means)[:, 1] / start.stds[:, 1]
    assert np.all(moved > 0.05) and np.all(moved < 0.5)  # a visible step toward higher returns, about alpha sigma (the paper's rule: < 1e-3)
    client.close()
