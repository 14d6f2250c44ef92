"""Run the chosen suites, collect their results with the machine's description, and
render them as JSON (atomically) and as a Markdown table."""
from __future__ import annotations

import datetime
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

from services.bench.config import NOT_IN_ALL, SUITES, BenchConfig
from services.bench.result import SuiteResult

REPO = Path(__file__).resolve().parents[2]


def _suite_functions():
    from services.bench.env_suite import run_env_suite, run_worker_suite
    from services.bench.learner_suite import run_learner_suite
    from services.bench.peer_suite import run_peer_suite
    from services.bench.pose_suite import run_pose_suite
    from services.bench.scaling_suite import run_scaling_suite
    from services.bench.system_suite import run_system_suite

    return {"env": run_env_suite, "worker": run_worker_suite, "learner": run_learner_suite,
            "system": run_system_suite, "peer": run_peer_suite, "pose": run_pose_suite, "scaling": run_scaling_suite}


def parse_suites(text: str) -> tuple[str, ...]:
    """'env', 'env,learner' or 'all' -> suite names in run order; ValueError names a bad one."""
    names = [s.strip() for s in text.split(",") if s.strip()]
    if not names:
        raise ValueError(f"no suite given; choose from {', '.join(SUITES)} or all")
    unknown = [n for n in names if n != "all" and n not in SUITES]
    if unknown:
        raise ValueError(f"unknown suite {unknown[0]!r}; choose from {', '.join(SUITES)} or all (or learning, on its own)")
    if "all" in names:
        return tuple(s for s in SUITES if s not in NOT_IN_ALL or s in names)
    return tuple(s for s in SUITES if s in names)


def machine() -> dict:
    import mujoco
    import numpy
    import torch

    info = {"platform": platform.platform(), "python": platform.python_version(),
            "cpus": os.cpu_count(), "usable_cpus": len(os.sched_getaffinity(0)), "mujoco": mujoco.__version__,
            "numpy": numpy.__version__, "torch": torch.__version__, "torch_threads": torch.get_num_threads()}
    try:
        commit = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True, text=True, timeout=10, check=False)
        dirty = subprocess.run(["git", "-C", str(REPO), "status", "--porcelain", "--untracked-files=no"], capture_output=True, text=True, timeout=10, check=False)
        if commit.returncode == 0:
            info["git_commit"] = commit.stdout.strip() + ("+dirty" if dirty.stdout.strip() else "")
    except (OSError, subprocess.TimeoutExpired):
        pass
    return info


def run_benchmarks(config: BenchConfig, log=None, command: str | None = None) -> dict:
    log = log or (lambda message: print(message, file=sys.stderr, flush=True))
    functions = _suite_functions()
    report = {"command": command, "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
              "quick": config.quick, "repeats": config.repeats, "machine": machine(),
              "load_average_start": list(os.getloadavg()), "suites": {}}
    for name in config.suites:
        log(f"suite {name}:")
        start = time.perf_counter()
        result: SuiteResult = functions[name](config, log)
        result.seconds = time.perf_counter() - start
        if result.skipped:
            log(f"  skipped: {result.skipped}")
        report["suites"][name] = result.to_dict()
    report["load_average_end"] = list(os.getloadavg())
    return report
