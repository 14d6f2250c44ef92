"""`sfv asi-server` as a process: bound address in the log, graceful SIGTERM, token, Redis restart."""
import subprocess
import sys

import numpy as np
import pytest

from actors.rollout.asi_client import ASIClient
from learner.errors import SfvError
from tests.asi_helpers import REPO_ROOT, K, ServerProcess, reference_clip
from tests.redis_fixture import free_port

pytestmark = pytest.mark.integration


def test_server_logs_its_address_and_stops_gracefully_on_sigterm(tmp_path):
    server = ServerProcess(tmp_path / "asi.log", "--port", "0")
    address = server.wait_listening()
    assert address.startswith("127.0.0.1:")
    states, phases = reference_clip()
    with ASIClient(address, "cli") as client:
        assert client.create_job(states, phases).created
    assert server.stop() == 0
    assert "stopping" in server.log_text()


def test_token_file_is_required_of_clients_and_never_logged(tmp_path):
    token = "tok-" + "9" * 24
    token_file = tmp_path / "token"
    token_file.write_text(token + "\n")
    server = ServerProcess(tmp_path / "asi.log", "--port", "0", "--token-file", str(token_file))
    try:
        address = server.wait_listening()
        states, phases = reference_clip()
        with pytest.raises(SfvError, match="UNAUTHENTICATED"), ASIClient(address, "t") as anonymous:
            anonymous.create_job(states, phases)
        with ASIClient(address, "t", token=token) as client:
            assert client.create_job(states, phases).created
    finally:
        assert server.stop() == 0
    assert token not in server.log_text() and "token auth" in server.log_text()


def test_token_from_environment(tmp_path):
    server = ServerProcess(tmp_path / "asi.log", "--port", "0", env={"SFV_ASI_TOKEN": "env-token"})
    try:
        address = server.wait_listening()
        with pytest.raises(SfvError, match="UNAUTHENTICATED"), ASIClient(address, "t") as anonymous:
            anonymous.sample("fsi", 1)
    finally:
        server.stop()
    assert "env-token" not in server.log_text()


def test_unreachable_redis_exits_2_with_one_redacted_line():
    url = f"redis://:pw-in-url@127.0.0.1:{free_port()}/0"
    result = subprocess.run([sys.executable, "-m", "services.commands.asi_server", "--port", "0", "--redis-url", url],
                            cwd=REPO_ROOT, capture_output=True, text=True, timeout=30)
    assert result.returncode == 2
    assert result.stderr.startswith("sfv: redis at redis://:***@127.0.0.1:") and "unreachable" in result.stderr
    assert "pw-in-url" not in result.stderr + result.stdout
    assert len(result.stderr.strip().splitlines()) == 1


def test_restarted_server_process_with_redis_carries_on(tmp_path, redis_url):
    states, phases = reference_clip()
    port = free_port()
    first = ServerProcess(tmp_path / "first.log", "--port", str(port), "--redis-url", redis_url)
    with ASIClient(first.wait_listening(), "resume") as client:
        client.create_job(states, phases, num_components=K, episodes_per_update=30)
        draw = client.sample("asi", 70, seed=2)
        assert client.report(draw.states, draw.components, draw.states[:, 1].astype(np.float64)) == 2
        before = client.get_distribution()
        assert first.stop() == 0
        second = ServerProcess(tmp_path / "second.log", "--port", str(port), "--redis-url", redis_url)
        try:
            second.wait_listening()
            after = client.get_distribution()  # the same client object reconnects to the new process
            assert (after.version, after.pending_episodes) == (before.version, before.pending_episodes) == (2, 10)
            np.testing.assert_array_equal(after.means, before.means)
            np.testing.assert_array_equal(after.stds, before.stds)
            assert client.create_job(states, phases, num_components=K).version == 2
        finally:
            assert second.stop() == 0
