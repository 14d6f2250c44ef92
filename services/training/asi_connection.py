"""The ASI server a training run talks to: an external one, or one embedded in the driver.

Without `--asi-address` the driver starts the server in-process (in-memory store, or Redis
with `--redis-url`) on a free port of `asi_host` (loopback by default). With a Ray cluster
and no external server, bind `--asi-host` to the head's cluster-network address so that
workers on other nodes reach it, or run `sfv asi-server` on its own.
A shared token, when set in SFV_ASI_TOKEN, is required by the server and sent by clients.
With `--asi-tls-ca FILE` the driver and the workers talk TLS to an external `sfv asi-server
--tls-cert/--tls-key` and check its certificate against FILE (the embedded server is plain).
"""
from __future__ import annotations

import os

import numpy as np

from actors.rollout.asi_client import ASIClient
from learner.errors import SfvError
from services.training.config import TrainConfig


class ASIConnection:
    def __init__(self, config: TrainConfig):
        self.config = config
        self.token = os.environ.get("SFV_ASI_TOKEN") or None
        self._server = None
        self.address = config.asi_address
        self.client: ASIClient | None = None

    def __enter__(self) -> "ASIConnection":
        try:
            return self._open()
        except BaseException:
            self.__exit__()  # an embedded server already started must not outlive the failure
            raise

    def _open(self) -> "ASIConnection":
        if self.address is None:
            from services.asi.server import serve
            from services.asi.store import InMemoryStore

            if self.config.redis_url:
                from services.asi.redis_store import RedisStore

                store = RedisStore(self.config.redis_url)
            else:
                store = InMemoryStore()
            self._server, _ = serve(0, store, host=self.config.asi_host, token=self.token)
            self.address = self._server.address
        self.client = ASIClient(self.address, self.config.job_id, token=self.token, tls_root_cert=self.config.asi_tls_ca)
        try:
            self.client.wait_until_ready(timeout=15.0)
        except SfvError as exc:
            if self._server is not None:
                raise
            tls = "with TLS (--asi-tls-ca)" if self.config.asi_tls_ca else "without TLS (no --asi-tls-ca)"
            raise SfvError(f"{exc}; is `sfv asi-server` running there, and does it serve {tls}?") from None
        return self

    def create_job(self, reference_states: np.ndarray, reference_phases: np.ndarray):
        c = self.config
        stds = None
        if c.asi_initial_std_scale != 1.0:  # 1.0: the server's default, the paper's clip std
            from services.asi.distribution import reference_std

            stds = np.maximum(c.asi_initial_std_scale * reference_std(np.asarray(reference_states, np.float64), 1e-3), 1e-3)
        return self.client.create_job(
            reference_states, reference_phases, num_components=c.asi_components, initial_stds=stds,
            step_size=c.asi_step_size, episodes_per_update=c.asi_episodes_per_update, update_rule=c.asi_update_rule,
            fall_weighting=c.asi_fall_weighting or None,  # 0: the request the server has always seen
        )

    def __exit__(self, *exc) -> None:
        if self.client is not None:
            self.client.close()
        if self._server is not None:
            self._server.stop(1.0).wait()
