"""The rollout worker: M imitation envs, batched policy inference, trajectories out.

One worker runs in its own process (a Ray actor in training; a plain object in the serial
runner and in benchmarks). Each `sample` call takes the learner's newest weights, steps all
envs `steps` times with one batched policy forward per step, and returns time-major numpy
arrays. Initial states come from the ASI server (ASI, and the server's RSI/FSI) or, without
a server, from the reference itself. Finished ASI episodes are reported back to the server
at the end of the call (one batched RPC).

ASI outages: the client retries each call with backoff for a few seconds; a report that
still fails is dropped and counted. Drawing starts cannot be skipped, so the client keeps
retrying a draw for up to `WorkerSpec.asi_outage_s` (a server restart takes seconds) before
the SfvError reaches the driver, which then stops training with that message.
"""
from __future__ import annotations

import logging
import os
import time
from dataclasses import dataclass

import numpy as np

from actors.envs.handover_starts import HandoverStarts
from actors.envs.imitation_env import EnvConfig
from actors.envs.initial_states import BufferedStarts, FirstFrameStarts, InitialStates, ReferenceStarts
from actors.motion.reference_motion import ReferenceMotion
from actors.envs.vector_env import VectorImitationEnv
from learner.policy import NumpyPolicy

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class WorkerSpec:
    """Everything a worker needs to build itself (picklable; Ray re-runs it on restart)."""

    motion: ReferenceMotion
    env: EnvConfig
    num_envs: int
    init: str  # "asi", "rsi" or "fsi"
    seed: int
    gamma: float = 0.95
    asi_address: str | None = None
    asi_job: str | None = None
    asi_token: str | None = None
    start_batch: int = 64
    asi_tls_ca: str | None = None  # PEM root certificate of a TLS ASI server (a path readable on every node)
    asi_outage_s: float = 30.0  # how long drawing starts keeps retrying an unreachable ASI server
    handover_states: np.ndarray | None = None  # (n, state_dim): a scene-fit window's starts at phase 0 (actors/envs/handover_starts.py)
    handover_share: float = 0.5  # share of episodes started from them
    first_frame_share: float = 0.0  # share of episodes started at the reference's first frame (FirstFrameStarts)
    start_phase_spread: float = 0.0  # a state start's phase spread uniformly over this width around its own (VectorImitationEnv)
    terrain_start_level: int = 0  # the terrain curriculum's level every env starts at (a resumed training's; 0: flat)


class _ServerStarts:
    """Starts drawn from the ASI server (any mode). Drawing cannot be skipped, so the client
    waits out an outage of up to `outage_s` (a server restart takes seconds) before the
    SfvError reaches the driver."""

    def __init__(self, client, mode: str, outage_s: float = 30.0, rng: np.random.Generator | None = None):
        self.client, self.mode, self.outage_s = client, mode, outage_s
        # Each draw carries a seed from the worker's own stream, so a serial run is reproducible
        # (the server draws from fresh entropy when no seed is sent).
        self.rng = rng

    def __call__(self, count: int) -> InitialStates:
        seed = None if self.rng is None else int(self.rng.integers(2**63))
        reply = self.client.sample(self.mode, count, seed=seed, outage_s=self.outage_s)
        return InitialStates(reply.phases, np.asarray(reply.components, np.int64), reply.states.astype(np.float64))


class RolloutWorker:
    def __init__(self, spec: WorkerSpec, worker_index: int = 0):
        # One BLAS thread: a multi-threaded OpenBLAS spinning against MuJoCo on the same cores
        # made a batch-16 policy forward 20x slower (81 ms instead of 4 ms, measured).
        from threadpoolctl import threadpool_limits

        threadpool_limits(1, user_api="blas")
        self.spec = spec
        self.worker_index = worker_index
        self.seed = spec.seed + worker_index  # RLlib's convention: base seed + worker index
        self.rng = np.random.default_rng(self.seed)
        self.client = None
        if spec.asi_address:
            from actors.rollout.asi_client import ASIClient  # gRPC only where a server is used

            self.client = ASIClient(spec.asi_address, spec.asi_job, token=spec.asi_token, tls_root_cert=spec.asi_tls_ca)
            source = _ServerStarts(self.client, spec.init, spec.asi_outage_s, rng=np.random.default_rng([self.seed, 1]))
        else:
            if spec.init == "asi":
                raise ValueError("init 'asi' needs an ASI server address")
            source = ReferenceStarts(spec.init, self.rng)
        starts = BufferedStarts(source, spec.start_batch)
        if spec.first_frame_share > 0:
            starts = FirstFrameStarts(starts, spec.first_frame_share, np.random.default_rng([self.seed, 3]))
        if spec.handover_states is not None:
            starts = HandoverStarts(starts, spec.handover_states, spec.handover_share, np.random.default_rng([self.seed, 2]))
        self.env = VectorImitationEnv(spec.motion, spec.env, spec.num_envs, starts, seed=self.seed * 1000, gamma=spec.gamma,
                                     start_phase_spread=spec.start_phase_spread, terrain_start_level=spec.terrain_start_level)
        self.policy: NumpyPolicy | None = None
        self._weights: dict | None = None
        self._started = False
        self.asi_version = 0

    @property
    def action_dim(self) -> int:
        return self.env.action_dim

    def ping(self) -> int:
        return self.worker_index

    def pid(self) -> int:
        """This worker's process id (a restarted Ray actor gets a new one)."""
        return os.getpid()

    def sample(self, weights: dict, policy_version: int, steps: int, horizon_s: float | None = None,
               residual_strength: float | None = None) -> dict[str, np.ndarray]:
        """Roll all envs forward `steps` control steps with the given policy weights;
        `horizon_s` caps the episodes that start during this call (a curriculum),
        `residual_strength` sets the residual root wrench's (a help that decays; None: as it is)."""
        t0 = time.perf_counter()
        self.env.set_horizon(horizon_s)
        if residual_strength is not None:  # only imitation envs carry a wrench (task envs have none)
            self.env.set_residual_strength(residual_strength)
        if self.policy is None:
            self.policy = NumpyPolicy(weights, max_batch=self.spec.num_envs)
        elif weights is not self._weights:  # in-process callers may hand the same dict again
            self.policy.load_weights(weights)
        self._weights = weights
        env, m = self.env, self.spec.num_envs
        if not self._started:
            env.reset()
            self._started = True
        batch = {
            "obs": np.empty((steps, m, env.obs_dim), np.float32),
            "next_obs": np.empty((steps, m, env.obs_dim), np.float32),
            "actions": np.empty((steps, m, env.action_dim), np.float32),
            "logp": np.empty((steps, m), np.float32),
            "rewards": np.empty((steps, m), np.float32),
            "terminated": np.empty((steps, m), bool),
            "truncated": np.empty((steps, m), bool),
            "frames": np.empty((steps, m), np.int32),  # reference row of obs[t]: adaptive tuple sampling's frame
        }
        for t in range(steps):
            batch["obs"][t] = env.obs
            batch["frames"][t] = env.rows
            self.policy.act(env.obs, self.rng, out_actions=batch["actions"][t], out_logp=batch["logp"][t])
            _, rewards, terminated, truncated, final_obs = env.step(batch["actions"][t])
            batch["next_obs"][t] = final_obs
            batch["rewards"][t] = rewards
            batch["terminated"][t] = terminated
            batch["truncated"][t] = truncated
        episodes = env.episodes.drain()
        if self.client is not None and self.spec.init == "asi" and len(episodes["components"]):
            self.asi_version = self.client.report(episodes["initial_states"], episodes["components"], episodes["discounted_returns"],
                                                  policy_version, fell=episodes["fell"])
        batch.update({f"episode_{k}": v for k, v in episodes.items() if k != "initial_states"})
        levels = env.terrain_levels()
        if levels is not None:  # the curriculum's state, which the driver's checkpoint keeps for --resume
            batch["terrain_levels"] = levels
        batch["policy_version"] = np.array(policy_version)
        batch["worker_index"] = np.array(self.worker_index)
        batch["worker_pid"] = np.array(os.getpid())
        batch["asi_version"] = np.array(self.asi_version)
        batch["asi_dropped_reports"] = np.array(self.client.dropped_reports if self.client else 0)
        batch["sample_seconds"] = np.array(time.perf_counter() - t0)
        return batch
