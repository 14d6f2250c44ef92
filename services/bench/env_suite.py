"""Suites `env` and `worker`: how close stepping gets to MuJoCo's own speed.

env:    raw physics vs the env's step vs a rollout worker with policy inference (M envs).
worker: the worker's batching sweep, M in `worker_envs`, each against the raw bound; with a
        terrain, M envs on it with and without the heightmap, and on the flat floor.
All variants run in this process, one core, interleaved in every repetition.
"""
from __future__ import annotations

from dataclasses import replace

from actors.character.actions import ActionMapper
from actors.character.features import observation_dim
from actors.character.humanoid import PhysicsConfig
from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.motion.formats.io import load_motion
from services.bench.config import TARGET_HEIGHTMAP_OVER_BLIND, TARGET_WORKER_OVER_RAW, BenchConfig
from services.bench.measure import Summary, interleaved, rate_for, ratio
from services.bench.result import SuiteResult
from services.bench.steppers import EnvStepper, RawPhysics, WorkerStepper, fresh_policy_weights

UNITS = {"_per_s": "control steps/s", "_per_cpu_s": "control steps per CPU-s"}


def step_summaries(runs: dict[str, list[float]]) -> dict[str, Summary]:
    return {name: Summary(tuple(values), UNITS["_per_cpu_s" if name.endswith("_per_cpu_s") else "_per_s"])
            for name, values in runs.items()}


def add_ratio_pair(result: SuiteResult, name: str, top: str, bottom: str, target: float | None = None) -> None:
    """The wall-clock ratio `name` and its CPU-time twin `name`_cpu."""
    result.ratios[name] = ratio(result.metrics, f"{top}_per_s", f"{bottom}_per_s", target=target)
    result.ratios[f"{name}_cpu"] = ratio(result.metrics, f"{top}_per_cpu_s", f"{bottom}_per_cpu_s", target=target)


def env_config_for(physics_hz: float) -> EnvConfig:
    config = EnvConfig(physics=PhysicsConfig(physics_hz=physics_hz))
    config.substeps  # noqa: B018  raises a clear ValueError for a rate that is not a multiple of control_hz
    return config


def _settings(config: BenchConfig, env_config: EnvConfig) -> dict:
    return {"motion": config.motion, "physics_hz": env_config.physics.physics_hz, "control_hz": env_config.control_hz,
            "substeps": env_config.substeps, "repeats": config.repeats, "seconds_per_measurement": config.seconds,
            "action_noise": config.action_noise, "policy_hidden": [1024, 512], "processes": 1}


def run_env_suite(config: BenchConfig, log) -> SuiteResult:
    env_config = env_config_for(config.physics_hz)
    motion = load_motion(config.motion)
    raw = RawPhysics(env_config)
    env = EnvStepper(motion, env_config, config.action_noise, config.seed)
    weights = fresh_policy_weights(env.env.action_space.shape[0], seed=config.seed, obs_dim=env.env.obs_dim)
    worker = WorkerStepper(motion, env_config, config.envs_per_worker, weights, config.seed)
    variants = {
        "raw": lambda: rate_for(config.seconds, raw.chunk).named("raw_steps"),
        "env": lambda: rate_for(config.seconds, env.chunk).named("env_steps"),
        "worker": lambda: rate_for(config.seconds, worker.chunk).named("worker_steps"),
    }
    runs = interleaved(variants, config.repeats, on_result=_progress(log))
    result = SuiteResult("env", step_summaries(runs), settings={**_settings(config, env_config), "envs_per_worker": config.envs_per_worker})
    add_ratio_pair(result, "env_over_raw", "env_steps", "raw_steps")
    add_ratio_pair(result, "worker_over_raw", "worker_steps", "raw_steps", target=TARGET_WORKER_OVER_RAW)
    result.notes.append(f"raw: open-loop humanoid, fixed PD targets, reset on root < 0.5 m or at the horizon ({raw.resets} resets); "
                        f"env: random actions, auto-reset ({env.resets} resets); worker: fresh policy, RSI, {worker.episodes} episodes ended")
    return result


def run_worker_suite(config: BenchConfig, log) -> SuiteResult:
    env_config = env_config_for(config.physics_hz)
    motion = load_motion(config.motion)
    raw = RawPhysics(env_config)
    variants = {"raw": lambda: rate_for(config.seconds, raw.chunk).named("raw_steps")}
    weights = fresh_policy_weights(ActionMapper(env_config.action_parameterisation).action_dim, seed=config.seed,
                                   obs_dim=observation_dim(len(env_config.reference_obs_steps)))
    for m in config.worker_envs:
        if m < 1:
            raise ValueError(f"worker_envs must be >= 1, got {m}")
        # At least 32 env steps per chunk, so that a small M still amortises the sample() call.
        stepper = WorkerStepper(motion, env_config, m, weights, config.seed, steps_per_sample=max(8, 32 // m))
        variants[f"worker_m{m}"] = lambda s=stepper, m=m: rate_for(config.seconds, s.chunk).named(f"worker_m{m}_steps")
    if config.terrain is not None:
        variants.update(_terrain_variants(config, env_config, motion))
    runs = interleaved(variants, config.repeats, on_result=_progress(log))
    result = SuiteResult("worker", step_summaries(runs), settings={**_settings(config, env_config), "worker_envs": list(config.worker_envs),
                                                                    "terrain": config.terrain})
    for m in config.worker_envs:
        add_ratio_pair(result, f"worker_m{m}_over_raw", f"worker_m{m}_steps", "raw_steps")
    if config.terrain is not None:
        add_ratio_pair(result, "heightmap_over_blind", "terrain_heightmap_steps", "terrain_blind_steps", target=TARGET_HEIGHTMAP_OVER_BLIND)
        add_ratio_pair(result, "terrain_over_flat", "terrain_heightmap_steps", "terrain_flat_steps")
    return result


def _terrain_variants(config: BenchConfig, env_config: EnvConfig, motion) -> dict:
    """M envs on the flat floor and on `config.terrain` at difficulty 1 (no curriculum) with and
    without the heightmap, each sampled by a fresh policy of its observation's width."""
    m = config.envs_per_worker
    variants = {}
    for name, settings in (("flat", {}), ("blind", {"heightmap": False}), ("heightmap", {"heightmap": True})):
        env = replace(env_config, **settings) if not settings else replace(env_config, terrain=config.terrain, terrain_difficulty=1.0,
                                                                              terrain_curriculum=False, **settings)
        obs_dim = ImitationEnv(motion, env).obs_dim
        weights = fresh_policy_weights(ActionMapper(env.action_parameterisation).action_dim, seed=config.seed, obs_dim=obs_dim)
        stepper = WorkerStepper(motion, env, m, weights, config.seed)
        variants[f"terrain_{name}"] = lambda s=stepper, n=name: rate_for(config.seconds, s.chunk).named(f"terrain_{n}_steps")
    return variants


def _progress(log):
    def report(repetition: int, name: str, value: float) -> None:
        log(f"  rep {repetition + 1}: {name} = {value:,.0f}")
    return report
