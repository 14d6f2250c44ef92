"""ASIClient against a real server: retries across an outage, dropped reports, no retry on bad requests."""
import threading
import time
from concurrent import futures

import grpc
import numpy as np
import pytest

from actors.rollout.asi_client import ASIClient
from learner.errors import SfvError
from proto import asi_pb2
from services.asi.server import serve
from services.asi.store import InMemoryStore
from tests.asi_helpers import D, K, reference_clip

pytestmark = pytest.mark.integration


def wait_for(condition, timeout=10.0, what="condition"):
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.01)


@pytest.fixture
def job():
    """(store, running server, port) with job 'j' created."""
    store = InMemoryStore()
    running, port = serve(0, store)
    states, phases = reference_clip()
    with ASIClient(running.address, "j") as client:
        client.create_job(states, phases, num_components=K, episodes_per_update=1000)
    yield store, running, port
    running.stop(None).wait()


def test_client_rides_out_a_brief_server_outage(job):
    store, running, port = job
    running.stop(None).wait()
    client = ASIClient(f"127.0.0.1:{port}", "j", timeout=2, max_retries=40, backoff=0.05, max_backoff=0.25)
    result = {}
    caller = threading.Thread(target=lambda: result.update(sample=client.sample("fsi", 3)))
    caller.start()
    wait_for(lambda: client.retries >= 2, what="the client to retry")
    restarted, same_port = serve(port, store)  # the same port, the same jobs
    try:
        caller.join(timeout=20)
        assert not caller.is_alive() and same_port == port
        np.testing.assert_array_equal(result["sample"].states, reference_clip()[0][[0, 0, 0]])
        assert client.retries >= 2
    finally:
        client.close()
        restarted.stop(None).wait()


def test_reports_are_dropped_and_counted_and_samples_raise_when_the_server_stays_down(job):
    store, running, port = job
    client = ASIClient(running.address, "j", timeout=1, max_retries=2, backoff=0.01, max_backoff=0.05)
    draw = client.sample("asi", 6)
    assert client.report(draw.states, draw.components, np.ones(6)) == 0
    running.stop(None).wait()
    start = time.monotonic()
    assert client.report(draw.states, draw.components, np.ones(6)) == 0  # no exception
    assert client.dropped_reports == 6 and client.retries == 2
    with pytest.raises(SfvError, match="after 2 retries"):
        client.sample("asi", 6)
    assert time.monotonic() - start < 10
    client.close()
    assert store.get_params("j").pending_episodes == 6  # only the first report arrived


def test_bad_requests_are_not_retried(job):
    _, running, _ = job
    with ASIClient(running.address, "j", max_retries=5) as client:
        with pytest.raises(SfvError, match="INVALID_ARGUMENT"):
            client.report(np.zeros((2, D)), [0, K], [1.0, 2.0])
        with pytest.raises(SfvError, match="INVALID_ARGUMENT"):
            client.report(np.full((1, D), np.nan), [0], [1.0])
        with pytest.raises(SfvError, match="NOT_FOUND"), ASIClient(running.address, "ghost") as ghost:
            ghost.sample("asi", 1)
        assert client.retries == 0 and client.dropped_reports == 0


def test_rsi_and_fsi_rows_are_not_reported(job):
    store, running, _ = job
    with ASIClient(running.address, "j") as client:
        draw = client.sample("rsi", 5)
        assert np.all(draw.components == -1)
        client.report(draw.states, draw.components, np.ones(5))
        asi = client.sample("asi", 4)
        mixed_states = np.concatenate([draw.states, asi.states])
        client.report(mixed_states, np.concatenate([draw.components, asi.components]), np.ones(9))
        assert client.get_distribution().pending_episodes == 4


def test_deadline_exceeded_is_retried():
    """A server whose first answer comes too late: the client times out, retries, and succeeds."""
    release = threading.Event()
    calls = []

    def get_distribution(request_bytes, context):
        calls.append(time.monotonic())
        if len(calls) == 1:
            release.wait(10)  # outlives the client's deadline
        return asi_pb2.Distribution(num_components=1, state_dim=1, means_f64=np.zeros(1).tobytes(),
                                    stds_f64=np.ones(1).tobytes(), phases=[0.0], version=7).SerializeToString()

    handler = grpc.method_handlers_generic_handler(
        "sfv.asi.v1.InitialStateService", {"GetDistribution": grpc.unary_unary_rpc_method_handler(get_distribution)})
    slow = grpc.server(futures.ThreadPoolExecutor(2), handlers=[handler])
    port = slow.add_insecure_port("127.0.0.1:0")
    slow.start()
    try:
        with ASIClient(f"127.0.0.1:{port}", "j", timeout=0.3, max_retries=3, backoff=0.01) as client:
            assert client.get_distribution().version == 7
            assert client.retries == 1 and len(calls) == 2
    finally:
        release.set()
        slow.stop(None).wait()


def test_client_imports_nothing_from_services_nor_the_learner_beyond_its_errors():
    import subprocess
    import sys

    from tests.asi_helpers import REPO_ROOT

    # The floor's error type is the only thing of learner/ a light gRPC client may pull in (no torch).
    code = ("import sys, actors.rollout.asi_client; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('services', 'learner', 'torch') and m != 'learner'))")
    result = subprocess.run([sys.executable, "-c", code], cwd=REPO_ROOT, capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "['learner.errors']"
