"""Running chunks of a video as Ray tasks, one core each, gathered in frame order."""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from services.pose.config import PoseConfig
from services.pose.models import PoseModelFiles
from services.ray_session import get_results, ray_session


def run_chunks_on_ray(video: Path, ranges: list[tuple[int, int]], files: PoseModelFiles,
                      config: PoseConfig, chunk_function: Callable) -> list:
    """One `ray.remote` task of `chunk_function(video, start, stop, files, config)` per (start,
    stop) range (the people tracker's `estimate_people_chunk`), results in range order. Starts a local Ray (num_cpus = os.cpu_count()) when none is initialised, and
    shuts it down again afterwards."""
    import ray

    with ray_session():
        task = ray.remote(num_cpus=1, max_retries=0)(chunk_function)
        return get_results([task.remote(str(video), start, stop, files, config) for start, stop in ranges])
