"""Running chunks of a video as Ray tasks, one core each, gathered in frame order."""
from __future__ import annotations

import os
from pathlib import Path

from services.errors import SfvError
from services.pose.config import PoseConfig
from services.pose.estimator import ChunkResult, estimate_chunk
from services.pose.models import PoseModelFiles

_REPO_ROOT = Path(__file__).resolve().parents[2]


def _start_local_ray() -> None:
    import ray

    # Workers must import `services` even when it is not installed (e.g. run from a checkout).
    python_path = os.pathsep.join(p for p in (str(_REPO_ROOT), os.environ.get("PYTHONPATH", "")) if p)
    ray.init(num_cpus=os.cpu_count() or 1, include_dashboard=False, logging_level="ERROR",
             runtime_env={"env_vars": {"PYTHONPATH": python_path}})


def run_chunks_on_ray(video: Path, ranges: list[tuple[int, int]], files: PoseModelFiles,
                      config: PoseConfig) -> list[ChunkResult]:
    """One `ray.remote` task per (start, stop) range. Starts a local Ray (num_cpus =
    os.cpu_count()) when none is initialised, and shuts it down again afterwards."""
    import ray

    started_here = not ray.is_initialized()
    if started_here:
        _start_local_ray()
    try:
        task = ray.remote(num_cpus=1, max_retries=0)(estimate_chunk)
        refs = [task.remote(str(video), start, stop, files, config) for start, stop in ranges]
        try:
            return ray.get(refs)
        except ray.exceptions.RayTaskError as exc:
            if isinstance(exc.cause, SfvError):
                raise SfvError(str(exc.cause)) from None
            raise
    finally:
        if started_here:
            ray.shutdown()
