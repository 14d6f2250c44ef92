"""Suite `scaling`: end-to-end training throughput against worker count, synchronous and
asynchronous, on the processes and Ray runners, and the learner/driver ceiling.

Every repetition runs, in rotating order, one short real training (`Trainer`: rollout workers,
embedded ASI server, PPO learner, metrics, checkpoints) per runner x worker count x loop
(`sync`: --max-policy-lag 0; `async`: --max-policy-lag 1), and the raw physics bound on one
core. Each run is measured in steady state, from its second iteration's record to its last
(start-up and the first sample() of fresh workers left out):
- samples/s, and its ratio to raw x min(workers, usable cores), the most those cores could
  simulate with nothing else to do;
- learner utilisation: the share of that wall time the PPO update ran;
- policy lag: the mean over shares of how many updates old the weights that drew them were.

Beside the single-core raw bound, the raw bound of N processes stepping at once
(`parallel_raw.py`, N = min(workers, cores)): its ratio to N x the single-core bound is what the
cores deliver together (shared caches, memory bandwidth, clocks), the part of the loss from one
worker to several that no training code can remove.

The ceiling: the same runs with synthetic workers (`recorded_worker.py`: each replays the
batch it first sampled, so sampling costs nothing) measure what the driver and the learner
consume at most, on `scaling_learner_threads` torch threads, whatever the number of cores.

A bigger machine, emulated (`scaling_paced_workers`): paced workers replay the same way but take
as long as a worker sampling `scaling_paced_rate` samples/s would, sleeping instead of stepping,
so 14 of them fit on 2 cores. The driver and the learner are real: this measures how samples/s
would grow with workers on a machine whose cores each sample at that rate, while its learner is
this machine's (`scaling_learner_threads` threads), and where the learner caps the loop.
"""
from __future__ import annotations

import gc
import os
import tempfile
from pathlib import Path

from services.bench.config import BenchConfig
from services.bench.env_suite import env_config_for
from services.bench.measure import Summary, interleaved, rate_for, ratio
from services.bench.parallel_raw import parallel_raw_steps_per_s
from services.bench.result import SuiteResult
from services.bench.steppers import RawPhysics

LOOPS = {"sync": 0, "async": 1}  # --max-policy-lag of each loop


KINDS = {"real": "scaling", "replay": "synthetic", "paced": "paced"}  # workers -> the metric names' prefix


def stem(runner: str, workers: int, loop: str, kind: str = "real") -> str:
    return f"{KINDS[kind]}_{runner}_{workers}w_{loop}"


def steady_state(rows: list[dict]) -> dict[str, float]:
    """Rates over a run's metrics rows from its second to its last (the first includes start-up)."""
    if len(rows) < 3:
        raise ValueError(f"a scaling run needs at least 3 iterations, got {len(rows)}")
    first, rest = rows[0], rows[1:]
    seconds = rest[-1]["time"] - first["time"]
    samples = rest[-1]["samples"] - first["samples"]
    return {"samples_per_s": samples / seconds,
            "learner_utilisation": sum(r["learner_update_s"] for r in rest) / seconds,
            "policy_lag": sum(r["policy_lag_mean"] for r in rest) / len(rest)}


def _train(config: BenchConfig, out: Path, runner: str, workers: int, lag: int, kind: str, value_bfloat16: bool = False) -> dict[str, float]:
    import functools

    from services.bench.recorded_worker import PacedWorker, RecordedWorker
    from services.training.config import TrainConfig
    from services.training.driver import Trainer
    from services.training.run_dir import read_metrics

    train = TrainConfig(motion=config.motion, out=str(out), workers=workers, envs_per_worker=config.envs_per_worker,
                        init="rsi", seed=config.seed, env=env_config_for(config.physics_hz), runner=runner,
                        max_policy_lag=lag, eval_every=0, plot_every=0, checkpoint_every=1000)
    train.samples = config.scaling_iterations * train.ppo.batch_size
    train.ppo.value_bfloat16 = value_bfloat16
    if kind != "real":
        train.torch_threads = config.scaling_learner_threads
        # A replayed batch is off-policy to every later version: the synchronous loop's updates
        # would stop at target_kl after their first minibatch (40 k "samples/s" measured, 0.8
        # utilisation), the asynchronous loop's not (decoupled clipping starts at ratio 1).
        # The ceiling is that of full updates: no early stop in either loop.
        train.ppo.target_kl = None
    trainer = Trainer(train, progress=False)
    if kind == "replay":
        trainer.worker_class = RecordedWorker
    elif kind == "paced":
        trainer.worker_class = functools.partial(PacedWorker, samples_per_s=config.scaling_paced_rate)
    with trainer:
        trainer.run()
    gc.collect()  # drop the run's actor handles so Ray frees their CPUs before the next run
    return steady_state(read_metrics(out))


def run_scaling_suite(config: BenchConfig, log) -> SuiteResult:
    import ray

    from services.ray_session import connect_ray

    cores = len(os.sched_getaffinity(0))
    counts = tuple(w for w in config.scaling_workers if w >= 1)
    started_ray = "ray" in config.scaling_runners and connect_ray(num_cpus=max(counts + (cores,)), log_to_driver=False)
    raw = RawPhysics(env_config_for(config.physics_hz))
    grid = [(runner, workers, loop, "real") for runner in config.scaling_runners for workers in counts for loop in LOOPS]
    grid += [("processes", workers, loop, "replay") for workers in config.scaling_synthetic_workers for loop in LOOPS]
    grid += [("processes", workers, loop, "paced") for workers in config.scaling_paced_workers for loop in LOOPS]
    try:
        with tempfile.TemporaryDirectory(prefix="sfv-bench-scaling-") as tmp:
            runs = iter(range(10**9))

            def variant(runner, workers, loop, kind):
                return lambda: {f"{stem(runner, workers, loop, kind)}_{k}": v for k, v in
                                _train(config, Path(tmp) / f"run{next(runs)}", runner, workers, LOOPS[loop], kind).items()}

            variants = {"raw_steps_per_s": lambda: rate_for(config.seconds, raw.chunk).wall}
            for n in _parallel_counts(counts, cores):
                variants[f"parallel_raw_{n}p_steps_per_s"] = lambda n=n: parallel_raw_steps_per_s(config.physics_hz, config.seconds, n)
            variants.update({stem(*key): variant(*key) for key in grid})
            values = interleaved(variants, config.repeats, warmup=1,
                                 on_result=lambda r, n, v: log(f"  rep {r + 1}: {n} = {v:,.3f}"))
    finally:
        if started_ray:
            ray.shutdown()
    return _result(config, values, grid, cores)


def _parallel_counts(counts: tuple[int, ...], cores: int) -> list[int]:
    return sorted({min(w, cores) for w in counts if min(w, cores) > 1})


def _result(config: BenchConfig, values: dict, grid: list, cores: int) -> SuiteResult:
    from services.bench.measure import Ratio

    units = {"samples_per_s": "samples/s (steady state, learning included)", "learner_utilisation": "share of wall time updating",
             "policy_lag": "updates (mean over shares)"}
    metrics = {"raw_steps_per_s": Summary(tuple(values["raw_steps_per_s"]), "control steps/s (1 core)")}
    parallel = _parallel_counts(tuple(config.scaling_workers), cores)
    for n in parallel:
        metrics[f"parallel_raw_{n}p_steps_per_s"] = Summary(tuple(values[f"parallel_raw_{n}p_steps_per_s"]),
                                                            f"control steps/s, {n} processes at once (sum)")
    for key in grid:
        for quantity, unit in units.items():
            name = f"{stem(*key)}_{quantity}"
            metrics[name] = Summary(tuple(values[name]), unit)
    settings = {"motion": config.motion, "physics_hz": config.physics_hz, "envs_per_worker": config.envs_per_worker,
                "iterations_per_run": config.scaling_iterations, "batch_size": 4096, "init": "rsi", "usable_cores": cores,
                "workers": list(config.scaling_workers), "runners": list(config.scaling_runners), "loops": LOOPS,
                "synthetic_workers": list(config.scaling_synthetic_workers),
                "synthetic_learner_threads": config.scaling_learner_threads, "repeats": config.repeats,
                "paced_workers": list(config.scaling_paced_workers), "paced_rate": config.scaling_paced_rate}
    result = SuiteResult("scaling", metrics, settings=settings)
    raw = metrics["raw_steps_per_s"]
    for runner, workers, loop, kind in grid:
        if kind != "real":
            continue
        name = stem(runner, workers, loop)
        top = metrics[f"{name}_samples_per_s"]
        scale = min(workers, cores)
        pairs = tuple(t / (scale * b) for t, b in zip(top.runs, raw.runs, strict=True))
        target = 0.70 if workers == 2 and cores == 2 else (0.6 if workers == 14 else None)
        result.ratios[f"{name}_over_raw"] = Ratio(f"{name}_samples_per_s", "raw_steps_per_s", top.median / (scale * raw.median),
                                                   pairs, target)
    for n in parallel:
        result.ratios[f"parallel_raw_{n}p_over_raw"] = ratio(metrics, f"parallel_raw_{n}p_steps_per_s", "raw_steps_per_s", scale=n)
    result.notes.append(f"raw bound x min(workers, {cores} usable cores): more workers than cores share them")
    return result


def plot_scaling(report: dict, out: Path) -> Path:
    """samples/s against workers, one line per runner and loop, beside the raw bound x cores."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    suite = report["suites"]["scaling"]
    metrics, settings = suite["metrics"], suite["settings"]
    counts, cores = settings["workers"], settings["usable_cores"]
    raw = metrics["raw_steps_per_s"]["median"]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.plot(counts, [raw * min(w, cores) for w in counts], "k--", label="raw physics bound x cores")
    for runner in settings["runners"]:
        for loop in settings["loops"]:
            ys = [metrics[f"{stem(runner, w, loop)}_samples_per_s"]["median"] for w in counts]
            ax.plot(counts, ys, "o-" if loop == "async" else "s:", label=f"{runner}, {loop}")
    for w in settings["synthetic_workers"]:  # the asynchronous loop's: the learner's full updates back to back
        ceiling = metrics[f"{stem('processes', w, 'async', 'replay')}_samples_per_s"]["median"]
        ax.axhline(ceiling, color="grey", lw=0.8)
        ax.annotate(f"learner/driver ceiling ({ceiling:,.0f})", (counts[0], ceiling), fontsize=7, va="bottom")
    paced = settings.get("paced_workers") or []
    if paced:  # emulated workers of a bigger machine: what they offer, and what this driver and learner took
        rate = settings["paced_rate"]
        ax.plot(paced, [rate * w for w in paced], color="tab:purple", ls="--", lw=0.8, label=f"emulated workers' offer ({rate:,.0f}/s each)")
        for loop in settings["loops"]:
            ys = [metrics[f"{stem('processes', w, loop, 'paced')}_samples_per_s"]["median"] for w in paced]
            ax.plot(paced, ys, "^-" if loop == "async" else "v:", color="tab:purple", label=f"emulated, {loop}")
    ax.set_xlabel("rollout workers")
    ax.set_ylabel("samples/s, learning included")
    ax.set_xticks(sorted(set(counts) | set(paced)))
    ax.set_title(f"sfv training throughput ({cores} cores)")
    ax.legend(fontsize=8, loc="center right")  # clear of the ceiling line (top) and the curves (bottom)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.stem + ".tmp" + out.suffix)
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    tmp.replace(out)
    return out
