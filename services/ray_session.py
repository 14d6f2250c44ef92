"""The one place that starts or joins Ray: training, pose and reconstruction tasks, the
pipeline and the benchmarks all come through here.

A local start is a private single-node Ray (`address="local"`: never a cluster someone else
started on this machine) whose workers can import the project from a checkout (PYTHONPATH in
the runtime env), without the dashboard and without Ray configuring the process's logging.
It is retried once on any failure: on a busy 2-core machine the raylet missed Ray's fixed 30 s
registration deadline (about once in 10 CI runs) and the GCS server its 30 s port-file
deadline (`Timed out waiting for file .../gcs_server_port_...`, seen on a quiet machine too).
"""
from __future__ import annotations

import logging
import os
from contextlib import contextmanager
from pathlib import Path

from learner.errors import SfvError

_REPO_ROOT = Path(__file__).resolve().parents[1]
LOCAL_START_ATTEMPTS = 2
log = logging.getLogger("sfv.ray")


def start_local_ray(num_cpus: int | None = None, log_to_driver: bool = True, attempts: int = LOCAL_START_ATTEMPTS) -> None:
    """A single-node Ray on this machine, retried on any start failure."""
    import ray

    python_path = os.pathsep.join(p for p in (str(_REPO_ROOT), os.environ.get("PYTHONPATH", "")) if p)
    for attempt in range(1, attempts + 1):
        try:
            ray.init(address="local", num_cpus=num_cpus or os.cpu_count() or 1, include_dashboard=False,
                     configure_logging=False, log_to_driver=log_to_driver,
                     runtime_env={"env_vars": {"PYTHONPATH": python_path}})
            return
        except Exception as exc:  # Ray raises a bare Exception (or RuntimeError) for start timeouts
            if attempt == attempts:
                raise
            log.warning("local Ray did not start (%s); trying again", str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
            ray.shutdown()


def connect_ray(address: str | None = None, num_cpus: int | None = None, log_to_driver: bool = True) -> bool:
    """Join the cluster at `address` (host:port or 'auto') or start a local Ray; nothing when
    Ray is running in this process already. Returns whether this call started it."""
    import ray

    if ray.is_initialized():
        return False
    if address:
        ray.init(address=address, log_to_driver=log_to_driver, configure_logging=False)
    else:
        start_local_ray(num_cpus, log_to_driver)
    return True


@contextmanager
def ray_session(address: str | None = None, num_cpus: int | None = None, log_to_driver: bool = True):
    """Ray for the block: the running one, or one joined or started here (and shut down after)."""
    import ray

    started_here = connect_ray(address, num_cpus, log_to_driver)
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
