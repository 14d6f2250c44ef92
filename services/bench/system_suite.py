"""Suite `system`: end-to-end `sfv train` throughput against the physics bound.

Each repetition runs the real training driver (`services.training.driver.Trainer`: rollout
workers, embedded ASI server, PPO learner, metrics, checkpoint, learning-curve plot) for a few
iterations with 1 and with 2 workers on each runner (Ray actors; spawned processes over pipes),
and times the raw physics bound on one core in between. Reported: `overall_samples_per_s` of
each run (samples over the training loop's wall time, learning included) and its ratio to raw
bound x workers, the most those cores could simulate with nothing else to do. The Ray runner's
metrics keep their first names (`system_2w_samples_per_s`); another runner's carry its name
(`system_processes_2w_samples_per_s`).
"""
from __future__ import annotations

import gc
import tempfile
from pathlib import Path

from services.bench.config import TARGET_SYSTEM_2W_OVER_RAW, BenchConfig
from services.bench.env_suite import env_config_for
from services.bench.measure import Summary, interleaved, rate_for, ratio
from services.bench.result import SuiteResult
from services.bench.steppers import RawPhysics


def variant_name(runner: str, workers: int) -> str:
    """The metric stem of one runner and worker count: `system_2w` (Ray), `system_processes_2w`."""
    return f"system_{workers}w" if runner == "ray" else f"system_{runner}_{workers}w"


def train_config(config: BenchConfig, out: Path, workers: int, iterations: int, runner: str = "ray"):
    from services.training.config import TrainConfig

    train = TrainConfig(motion=config.motion, out=str(out), workers=workers, envs_per_worker=config.envs_per_worker,
                        init="asi", seed=config.seed, env=env_config_for(config.physics_hz), runner=runner)
    train.samples = iterations * train.ppo.batch_size
    return train


def run_system_suite(config: BenchConfig, log) -> SuiteResult:
    import ray

    from services.ray_session import connect_ray
    from services.training.driver import Trainer

    from services.training.config import RUNNER_NAMES

    if any(w < 1 for w in config.system_workers):
        raise ValueError(f"system_workers must be >= 1, got {config.system_workers}")
    unknown = [r for r in config.system_runners if r not in RUNNER_NAMES]
    if unknown or not config.system_runners:
        raise ValueError(f"system_runners must be some of {', '.join(RUNNER_NAMES)}, got {', '.join(config.system_runners) or 'none'}")
    started_ray = "ray" in config.system_runners and connect_ray(num_cpus=max(config.system_workers), log_to_driver=False)
    raw = RawPhysics(env_config_for(config.physics_hz))
    grid = [(runner, workers) for runner in config.system_runners for workers in config.system_workers]
    records: dict[tuple[str, int], list[dict]] = {key: [] for key in grid}
    try:
        with tempfile.TemporaryDirectory(prefix="sfv-bench-system-") as tmp:
            runs = {"n": 0}

            def train(runner: str, workers: int, iterations: int) -> float:
                runs["n"] += 1
                train_cfg = train_config(config, Path(tmp) / f"run{runs['n']}", workers, iterations, runner)
                record = Trainer(train_cfg, progress=False).run()
                gc.collect()  # drop the run's actor handles so Ray frees their CPUs before the next run
                records[runner, workers].append(record)
                return record["overall_samples_per_s"]

            log("  warm-up: one iteration with every runner and worker count")
            for runner, workers in grid:
                train(runner, workers, 1)
            for kept in records.values():
                kept.clear()
            variants = {"raw_steps_per_s": lambda: rate_for(config.seconds, raw.chunk).wall}
            for runner, workers in grid:
                variants[f"{variant_name(runner, workers)}_samples_per_s"] = lambda r=runner, w=workers: train(r, w, config.system_iterations)
            values = interleaved(variants, config.repeats, warmup=0,
                                 on_result=lambda r, n, v: log(f"  rep {r + 1}: {n} = {v:,.0f}"))
    finally:
        if started_ray:
            ray.shutdown()
    metrics = {"raw_steps_per_s": Summary(tuple(values["raw_steps_per_s"]), "control steps/s (1 core)")}
    for runner, workers in grid:
        stem = variant_name(runner, workers)
        metrics[f"{stem}_samples_per_s"] = Summary(tuple(values[f"{stem}_samples_per_s"]), f"samples/s incl. learning ({runner} runner)")
        sampling = tuple(r["sampling_samples_per_s"] for r in records[runner, workers])
        metrics[f"{stem}_sampling_samples_per_s"] = Summary(sampling, f"samples/s while sampling, last iteration ({runner} runner)")
    settings = {"motion": config.motion, "physics_hz": config.physics_hz, "envs_per_worker": config.envs_per_worker,
                "iterations_per_run": config.system_iterations, "batch_size": 4096, "init": "asi",
                "system_workers": list(config.system_workers), "system_runners": list(config.system_runners),
                "ray": "local, num_cpus = max workers", "repeats": config.repeats}
    result = SuiteResult("system", metrics, settings=settings)
    for runner, workers in grid:
        stem = variant_name(runner, workers)
        target = TARGET_SYSTEM_2W_OVER_RAW if workers == 2 else None
        result.ratios[f"{stem}_over_raw"] = ratio(metrics, f"{stem}_samples_per_s", "raw_steps_per_s", scale=workers, target=target)
    result.notes.append("the training loop's time includes the first sample() of fresh actors, the final checkpoint and "
                        "learning-curve plot, as in `sfv train`; actor start-up is excluded")
    return result
