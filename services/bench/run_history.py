"""What a run directory says about its own past: training time from its metrics, and whether it
was trained with the settings a benchmark cell asks for.

The learning suite records the wall time of the invocations that trained a run. A run continued
across sessions (`--resume`), or trained by `sfv train` and then moved into a suite's out-dir to be
recorded there, needs its time from the run itself: every metrics row carries the wall clock of its
iteration (`time`), so the training time is the sum of the gaps between consecutive rows, leaving
out gaps longer than BREAK_S (the process was stopped and resumed later: a gap of minutes to hours
between two rows, where an iteration of 4,096 samples takes about a second and an in-training
evaluation of 8 episodes about 10-40 s here).
"""
from __future__ import annotations

import json
import math

BREAK_S = 300.0  # a longer gap between two metrics rows is a stop and a resume, not training time
# Settings that say how a run was operated, not what it learned: they may differ between a run
# trained by `sfv train` and the benchmark cell that records it.
OPERATIONAL = frozenset({
    "out", "job_id", "samples", "runner", "ray_address", "redis_url", "asi_address", "asi_host",
    "asi_tls_ca", "asi_outage_s", "worker_timeout_s", "device", "torch_threads", "eval_every", "eval_episodes",
    "checkpoint_every", "keep_checkpoints", "plot_every", "plot_min_interval_s",
})


def active_seconds(rows: list[dict]) -> list[float | None]:
    """Per metrics row, the training seconds up to it: gaps between consecutive `time` stamps
    summed, gaps over BREAK_S left out. The first row counts one iteration at its own rate
    (samples / samples_per_s). None for rows without a time stamp (old metrics files)."""
    out: list[float | None] = []
    total, previous_time, previous_samples = 0.0, None, 0
    for row in rows:
        stamp = row.get("time")
        if not isinstance(stamp, (int, float)):
            out.append(None)
            continue
        if previous_time is None:
            rate = row.get("samples_per_s")
            samples = row.get("samples") or 0
            total += samples / rate if isinstance(rate, (int, float)) and rate > 0 else 0.0
        else:
            gap = stamp - previous_time
            if 0.0 <= gap <= BREAK_S:
                total += gap
            elif gap > BREAK_S and row.get("samples") and row["samples"] > previous_samples:
                # a resume: the first iteration after it, at its own rate
                rate = row.get("samples_per_s")
                total += (row["samples"] - previous_samples) / rate if isinstance(rate, (int, float)) and rate > 0 else 0.0
        previous_time = stamp
        previous_samples = row.get("samples") or previous_samples
        out.append(total)
    return out


def training_seconds(rows: list[dict]) -> float | None:
    """The run's training time from its metrics (None when no row has a time stamp)."""
    known = [s for s in active_seconds(rows) if s is not None]
    return known[-1] if known else None


def _flat(d: dict, prefix: str = "") -> dict:
    out = {}
    for key, value in d.items():
        if isinstance(value, dict):
            out.update(_flat(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


def _same(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float):
        return math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    return a == b


def setting_differences(saved: dict, wanted: dict) -> list[str]:
    """Dotted names of the settings (besides the operational ones) on which a run's saved config
    differs from the one wanted; both as `TrainConfig.to_dict()` writes them."""
    saved_flat = _flat(json.loads(json.dumps(saved)))
    wanted_flat = _flat(json.loads(json.dumps(wanted)))  # tuples as lists, as config.json holds them
    names = sorted(set(saved_flat) | set(wanted_flat))
    return [name for name in names
            if name.split(".", 1)[0] not in OPERATIONAL and not _same(saved_flat.get(name), wanted_flat.get(name))]
