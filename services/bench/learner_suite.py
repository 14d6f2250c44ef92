"""Suite `learner`: PPO update throughput at the paper's sizes.

One `PPOLearner.update` on a random time-major batch of 4096 samples (obs 197, act 36),
minibatch 256, 1024-512 policy and value networks, all `update_epochs` passes
(`target_kl` off, so random data cannot stop an update early). Reported per epoch:
samples/s = batch * epochs / update time, the rate at which gradient passes consume data.
"""
from __future__ import annotations

import time

import numpy as np
import torch

from actors.character.actions import ActionMapper
from actors.character.features import OBS_DIM
from learner.config import PPOConfig
from learner.ppo import PPOLearner
from services.bench.config import BenchConfig
from services.bench.measure import Summary, interleaved, ratio
from services.bench.result import SuiteResult

ACTION_DIM = ActionMapper("axis_angle").action_dim  # SFV's action of the humanoid3d: 36
ENVS = 64  # time-major layout (T, N) as two workers x 32 envs deliver it


def random_batch(rng: np.random.Generator, samples: int, envs: int = ENVS) -> dict[str, np.ndarray]:
    """Random trajectories laid out as workers deliver them: within an episode next_obs[t] is
    obs[t + 1]; after an episode end (and at the last step) it is a fresh observation."""
    steps = -(-samples // envs)
    shape = (steps, envs)
    obs = rng.standard_normal((steps + 1, envs, OBS_DIM), dtype=np.float32)
    terminated, truncated = rng.random(shape) < 0.01, rng.random(shape) < 0.005
    next_obs = obs[1:].copy()
    ended = terminated | truncated
    next_obs[ended] = rng.standard_normal((int(ended.sum()), OBS_DIM), dtype=np.float32)
    return {
        "obs": obs[:-1],
        "next_obs": next_obs,
        "actions": rng.uniform(-1, 1, (*shape, ACTION_DIM)).astype(np.float32),
        "logp": rng.standard_normal(shape, dtype=np.float32),
        "rewards": rng.uniform(0, 1, shape).astype(np.float32),
        "terminated": terminated,
        "truncated": truncated,
    }


def thread_counts() -> tuple[int, ...]:
    """1 and torch's default intra-op thread count: on a shared machine more threads can be
    much slower (threads wait on each other while the OS runs someone else)."""
    return tuple(sorted({1, torch.get_num_threads()}))


def run_learner_suite(config: BenchConfig, log, device: str = "cpu") -> SuiteResult:
    ppo = PPOConfig(target_kl=None, seed=config.seed)
    learner = PPOLearner(OBS_DIM, ACTION_DIM, ppo, device=device)
    batch = random_batch(np.random.default_rng(config.seed), ppo.batch_size)
    samples = batch["rewards"].size
    steps_seen: list[float] = []
    default_threads = torch.get_num_threads()

    def update_with(threads: int) -> float:
        torch.set_num_threads(threads)
        try:
            start = time.perf_counter()
            metrics = learner.update(batch)
            seconds = time.perf_counter() - start
        finally:
            torch.set_num_threads(default_threads)
        steps_seen.append(metrics["charts/gradient_steps"])
        return samples * ppo.update_epochs / seconds

    counts = thread_counts()
    variants = {f"learner_samples_per_s_{n}t": lambda n=n: update_with(n) for n in counts}
    runs = interleaved(variants, config.repeats, on_result=lambda r, n, v: log(f"  rep {r + 1}: {n} = {v:,.0f}"))
    metrics = {}
    for n in counts:
        rates = tuple(runs[f"learner_samples_per_s_{n}t"])
        metrics[f"learner_samples_per_s_{n}t"] = Summary(rates, f"samples/s per epoch, {n} torch thread{'s' if n > 1 else ''}")
        metrics[f"learner_update_s_{n}t"] = Summary(tuple(samples * ppo.update_epochs / v for v in rates), "s per update")
    settings = {"batch_size": samples, "minibatch_size": ppo.minibatch_size, "update_epochs": ppo.update_epochs,
                "obs_dim": OBS_DIM, "act_dim": ACTION_DIM, "policy_hidden": list(ppo.policy_hidden),
                "value_hidden": list(ppo.value_hidden), "optimizer": ppo.optimizer, "target_kl": None, "device": device,
                "torch_threads": list(counts), "repeats": config.repeats}
    result = SuiteResult("learner", metrics, settings=settings)
    if len(counts) > 1:
        result.ratios[f"threads_{counts[-1]}_over_1"] = ratio(metrics, f"learner_samples_per_s_{counts[-1]}t", "learner_samples_per_s_1t")
    expected = ppo.update_epochs * max(1, round(samples / ppo.minibatch_size))
    if any(s != expected for s in steps_seen):
        result.notes.append(f"some updates ran {sorted(set(steps_seen))} gradient steps instead of {expected}")
    result.notes.append("an update includes value evaluation, GAE/TD(lambda), batch checks and update()'s state backup")
    return result
