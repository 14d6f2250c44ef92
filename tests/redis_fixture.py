"""A real redis-server on a free loopback port for tests.

Import the fixtures in tests/conftest.py:  from tests.redis_fixture import redis_server, redis_url  # noqa: F401
Tests skip (with the reason) only when redis-server is not installed.
"""
from __future__ import annotations

import shutil
import socket
import subprocess
import time
from pathlib import Path

import pytest

REDIS_BINARY = "redis-server"
START_TIMEOUT_S = 10.0
SHUTDOWN_TIMEOUT_S = 30.0


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


class RedisProcess:
    """One redis-server process in `workdir`; restart() keeps the port and the data (via an RDB dump)."""

    def __init__(self, workdir: Path, port: int | None = None, password: str | None = None):
        self.workdir = Path(workdir)
        self.port = port or free_port()
        self.password = password
        self.process: subprocess.Popen | None = None

    @property
    def url(self) -> str:
        auth = f":{self.password}@" if self.password else ""
        return f"redis://{auth}127.0.0.1:{self.port}/0"

    def _client(self, socket_timeout: float = 0.5):
        import redis
        from redis.backoff import NoBackoff
        from redis.retry import Retry

        # No client retries: polling and SHUTDOWN handle a closed connection themselves.
        return redis.Redis(host="127.0.0.1", port=self.port, password=self.password,
                           socket_connect_timeout=0.5, socket_timeout=socket_timeout, retry=Retry(NoBackoff(), 0))

    def start(self) -> "RedisProcess":
        # --save '' disables periodic snapshots; restart() forces one with SHUTDOWN SAVE.
        command = [REDIS_BINARY, "--port", str(self.port), "--bind", "127.0.0.1", "--save", "", "--appendonly", "no",
                   "--dir", str(self.workdir), "--dbfilename", "dump.rdb"]
        if self.password:
            command += ["--requirepass", self.password]
        self.process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        self._wait_ready()
        return self

    def _wait_ready(self) -> None:
        import redis

        deadline = time.monotonic() + START_TIMEOUT_S
        client = self._client()
        try:
            while True:
                if self.process.poll() is not None:
                    raise RuntimeError(f"redis-server on port {self.port} exited: "
                                       f"{self.process.stderr.read().decode(errors='replace').strip()}")
                try:
                    if client.ping():
                        return
                except redis.RedisError:
                    pass
                if time.monotonic() > deadline:
                    raise RuntimeError(f"redis-server on port {self.port} did not answer PING in {START_TIMEOUT_S} s")
                time.sleep(0.02)
        finally:
            client.close()

    def stop(self, save: bool = False) -> None:
        """Stop the server; with save=True first write dump.rdb so the next start loads the data."""
        if self.process is None or self.process.poll() is not None:
            return
        if save:
            import redis

            # SHUTDOWN SAVE writes and fsyncs dump.rdb before it answers: 0.5 s was too short on a
            # loaded CI disk (stop 33 failed there with a read timeout), so this call waits up to 30 s.
            client = self._client(socket_timeout=SHUTDOWN_TIMEOUT_S)
            try:
                client.shutdown(save=True)
            except redis.ConnectionError:
                pass  # the server closes the connection as it exits
            finally:
                client.close()
        else:
            self.process.terminate()
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        self.process.stderr.close()

    def restart(self) -> None:
        """Same port, same data."""
        self.stop(save=True)
        self.start()


def _redis_process(tmp_path: Path, password: str | None = None):
    if shutil.which(REDIS_BINARY) is None:
        pytest.skip(f"{REDIS_BINARY} not installed")
    process = RedisProcess(tmp_path, password=password).start()
    try:
        yield process
    finally:
        process.stop()


@pytest.fixture
def redis_server(tmp_path_factory):
    """A running RedisProcess (no password), stopped after the test."""
    yield from _redis_process(tmp_path_factory.mktemp("redis"))


@pytest.fixture
def redis_url(redis_server) -> str:
    """redis://127.0.0.1:N/0 of a fresh redis-server."""
    return redis_server.url


@pytest.fixture
def redis_server_with_password(tmp_path_factory):
    """A RedisProcess started with --requirepass; its url carries the password."""
    yield from _redis_process(tmp_path_factory.mktemp("redis"), password="s3cret-pw")
