"""Running Ray tasks from a command: reuse the running Ray or start a local one, and turn a
task's user-facing error back into the one-line `SfvError` it was."""
from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path

from learner.errors import SfvError

_REPO_ROOT = Path(__file__).resolve().parents[1]


def start_local_ray(num_cpus: int | None = None) -> None:
    """A single-node Ray on this machine whose workers can import the project from a checkout."""
    import ray

    python_path = os.pathsep.join(p for p in (str(_REPO_ROOT), os.environ.get("PYTHONPATH", "")) if p)
    ray.init(num_cpus=num_cpus or os.cpu_count() or 1, include_dashboard=False, logging_level="ERROR",
             runtime_env={"env_vars": {"PYTHONPATH": python_path}})


@contextmanager
def ray_session():
    """The running Ray, or a local one started (and shut down) for the block."""
    import ray

    started_here = not ray.is_initialized()
    if started_here:
        start_local_ray()
    try:
        yield
    finally:
        if started_here:
            ray.shutdown()


def get_results(refs):
    """ray.get, re-raising a task's SfvError as itself (one line, no Ray traceback)."""
    import ray

    try:
        return ray.get(refs)
    except ray.exceptions.RayTaskError as exc:
        if isinstance(exc.cause, SfvError):
            raise SfvError(str(exc.cause)) from None
        raise
