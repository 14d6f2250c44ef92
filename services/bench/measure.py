"""Repeated, interleaved measurements and their summaries.

Machines are shared and noisy, so a benchmark never compares two numbers taken minutes
apart: every repetition measures each variant once, in an order that rotates from one
repetition to the next (so no variant always runs first, right after a warm cache or a
quiet moment), and each comparison is the ratio of the variants' medians over the same
repetitions. The per-repetition ratios are kept too: their spread shows how much the noise
moved the comparison.

Stepping variants report two rates: per second of wall time (what a process gets) and per
CPU-second of this process (what a step costs). On a quiet machine they agree; on a shared
one the wall rate swings with everyone else's load while the CPU rate stays close to the
cost, so the CPU-time ratios are the steadier comparison.
"""
from __future__ import annotations

import statistics
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import NamedTuple

# A variant does one measurement per call and returns a value, or several named values.
Variant = Callable[[], "float | Mapping[str, float]"]


@dataclass(frozen=True)
class Summary:
    """min, median and max of repeated measurements of one quantity."""

    runs: tuple[float, ...]
    unit: str

    @property
    def min(self) -> float:
        return min(self.runs)

    @property
    def median(self) -> float:
        return statistics.median(self.runs)

    @property
    def max(self) -> float:
        return max(self.runs)

    def to_dict(self) -> dict:
        return {"min": self.min, "median": self.median, "max": self.max, "unit": self.unit, "runs": list(self.runs)}


@dataclass(frozen=True)
class Ratio:
    """numerator / denominator of two summaries measured in the same repetitions."""

    numerator: str
    denominator: str
    value: float  # median(numerator) / median(denominator)
    per_repetition: tuple[float, ...]
    target: float | None = None

    def to_dict(self) -> dict:
        out = {
            "value": self.value,
            "numerator": self.numerator,
            "denominator": self.denominator,
            "per_repetition": {"min": min(self.per_repetition), "median": statistics.median(self.per_repetition),
                               "max": max(self.per_repetition), "runs": list(self.per_repetition)},
        }
        if self.target is not None:
            out["target"] = self.target
            out["meets_target"] = self.value >= self.target
        return out


def ratio(metrics: Mapping[str, Summary], numerator: str, denominator: str, scale: float = 1.0,
          target: float | None = None) -> Ratio:
    """median(numerator) / (scale * median(denominator)); scale is e.g. a core count."""
    top, bottom = metrics[numerator], metrics[denominator]
    pairs = tuple(t / (scale * b) for t, b in zip(top.runs, bottom.runs, strict=True))
    return Ratio(numerator, denominator, top.median / (scale * bottom.median), pairs, target)


def interleaved(variants: Mapping[str, Variant], repeats: int, warmup: int = 1,
                on_result: Callable[[int, str, float], None] | None = None) -> dict[str, list[float]]:
    """Run every variant `warmup` times (discarded), then `repeats` times, rotating the order.

    Returns {name: [value of repetition 0, 1, ...]}; repetition r starts with variant r mod n.
    A variant that returns a mapping contributes one list per key instead of one under its name.
    """
    if repeats < 1:
        raise ValueError(f"repeats must be >= 1, got {repeats}")
    names = list(variants)
    for _ in range(warmup):
        for name in names:
            variants[name]()
    runs: dict[str, list[float]] = {}
    for r in range(repeats):
        k = r % len(names)
        for name in names[k:] + names[:k]:
            value = variants[name]()
            for key, v in (value.items() if isinstance(value, Mapping) else [(name, value)]):
                runs.setdefault(key, []).append(v)
                if on_result is not None:
                    on_result(r, key, v)
    return runs


class Rates(NamedTuple):
    wall: float  # units per second of wall time
    cpu: float  # units per CPU-second of this process (all its threads)

    def named(self, prefix: str) -> dict[str, float]:
        """{"<prefix>_per_s": wall, "<prefix>_per_cpu_s": cpu}"""
        return {f"{prefix}_per_s": self.wall, f"{prefix}_per_cpu_s": self.cpu}


def rate_for(seconds: float, chunk: Callable[[], int]) -> Rates:
    """Call `chunk` (which does some work and returns how many units it did) until at least
    `seconds` of wall time have passed; units per wall second and per CPU-second."""
    units = 0
    start, cpu_start = time.perf_counter(), time.process_time()
    while True:
        units += chunk()
        elapsed = time.perf_counter() - start
        if elapsed >= seconds:
            return Rates(units / elapsed, units / max(time.process_time() - cpu_start, 1e-9))
