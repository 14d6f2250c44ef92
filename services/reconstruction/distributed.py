"""Reconstruction as a Ray task (one CPU; torch then runs single-threaded inside it)."""
from __future__ import annotations

import os
from pathlib import Path

from actors.errors import SfvError
from actors.motion import ReferenceMotion
from services.reconstruction.config import ReconstructionConfig
from services.reconstruction.reconstruct import reconstruct_track

_REPO_ROOT = Path(__file__).resolve().parents[2]


def start_local_ray(num_cpus: int | None = None) -> None:
    """A single-node Ray on this machine whose workers can import the project from a checkout."""
    import ray

    python_path = os.pathsep.join(p for p in (str(_REPO_ROOT), os.environ.get("PYTHONPATH", "")) if p)
    ray.init(num_cpus=num_cpus or os.cpu_count() or 1, include_dashboard=False, logging_level="ERROR",
             runtime_env={"env_vars": {"PYTHONPATH": python_path}})


def reconstruct_task():
    """The `ray.remote` version of `reconstruct_track` (built on first use, so importing this
    module does not import Ray)."""
    import ray

    return ray.remote(num_cpus=1, max_retries=0)(reconstruct_track)


def reconstruct_on_ray(track, config: ReconstructionConfig | None = None, name: str = "reconstruction") -> ReferenceMotion:
    """Run `reconstruct_track` as a Ray task and wait for it. Uses the running Ray when there
    is one; otherwise starts a local one and shuts it down afterwards."""
    import ray

    started_here = not ray.is_initialized()
    if started_here:
        start_local_ray()
    try:
        ref = reconstruct_task().remote(track, config or ReconstructionConfig(), name)
        try:
            return ray.get(ref)
        except ray.exceptions.RayTaskError as exc:
            if isinstance(exc.cause, SfvError):
                raise SfvError(str(exc.cause)) from None
            raise
    finally:
        if started_here:
            ray.shutdown()
