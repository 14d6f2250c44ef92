"""The one place that starts or joins Ray: training, pose and reconstruction tasks, the
pipeline and the benchmarks all come through here.

A local start is a private single-node Ray (`address="local"`: never a cluster someone else
started on this machine) whose workers can import the project from a checkout (PYTHONPATH in
the runtime env), without the dashboard and without Ray configuring the process's logging.
It is retried once on any failure: on a busy 2-core machine the raylet missed Ray's fixed 30 s
registration deadline (about once in 10 CI runs) and the GCS server its 30 s port-file
deadline (`Timed out waiting for file .../gcs_server_port_...`, seen on a quiet machine too).

Quiet by default: the workers' output stays in Ray's session log folder (its path goes to the
run's log file, `services/console.py`) instead of being forwarded to the terminal with Ray's
`(task pid=...)` prefixes; `sfv --verbose` forwards it (`log_to_driver=None` means: as verbose
says).
"""
from __future__ import annotations

import logging
import os
from contextlib import contextmanager
from pathlib import Path

from learner.errors import SfvError
from services.console import is_verbose

_REPO_ROOT = Path(__file__).resolve().parents[1]
LOCAL_START_ATTEMPTS = 2
log = logging.getLogger("sfv.ray")


def _forward_worker_output(log_to_driver: bool | None) -> bool:
    return is_verbose() if log_to_driver is None else bool(log_to_driver)


def _quiet_ray_logger() -> None:
    """Ray's own logger prints to stderr past the root logger (its token-authentication banner):
    send its records through the root logger instead, where `services/console.py` routes them to
    the run's log file; `--verbose` keeps Ray's handler."""
    if is_verbose():
        return
    ray_logger = logging.getLogger("ray")
    for handler in list(ray_logger.handlers):
        ray_logger.removeHandler(handler)
    ray_logger.propagate = True


def _note_session_logs() -> None:
    """Name the folder with the workers' output in the log (the run's log file)."""
    try:
        from ray._private.worker import global_worker

        log.info("Ray workers' output: %s", Path(global_worker.node.get_session_dir_path()) / "logs")
    except Exception:  # noqa: BLE001  (a private Ray API: the note is optional)
        pass


def start_local_ray(num_cpus: int | None = None, log_to_driver: bool | None = None, attempts: int = LOCAL_START_ATTEMPTS) -> None:
    """A single-node Ray on this machine, retried on any start failure."""
    import ray

    log_to_driver = _forward_worker_output(log_to_driver)
    _quiet_ray_logger()

    python_path = os.pathsep.join(p for p in (str(_REPO_ROOT), os.environ.get("PYTHONPATH", "")) if p)
    for attempt in range(1, attempts + 1):
        try:
            ray.init(address="local", num_cpus=num_cpus or os.cpu_count() or 1, include_dashboard=False,
                     configure_logging=False, log_to_driver=log_to_driver, logging_level=logging.WARNING,
                     runtime_env={"env_vars": {"PYTHONPATH": python_path}})
            _note_session_logs()
            return
        except Exception as exc:  # Ray raises a bare Exception (or RuntimeError) for start timeouts
            if attempt == attempts:
                log.error("local Ray did not start", exc_info=True)  # the traceback goes to the run's log file
                ray.shutdown()
                first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
                raise SfvError(f"local Ray did not start in {attempts} attempts ({first}); Ray's logs: /tmp/ray/session_latest/logs") from None
            log.warning("local Ray did not start (%s); trying again", str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
            ray.shutdown()


def connect_ray(address: str | None = None, num_cpus: int | None = None, log_to_driver: bool | None = None) -> bool:
    """Join the cluster at `address` (host:port or 'auto') or start a local Ray; nothing when
    Ray is running in this process already. Returns whether this call started it."""
    import ray

    if ray.is_initialized():
        return False
    if address:
        _quiet_ray_logger()
        ray.init(address=address, log_to_driver=_forward_worker_output(log_to_driver), configure_logging=False,
                 logging_level=logging.WARNING)
        _note_session_logs()
    else:
        start_local_ray(num_cpus, log_to_driver)
    return True


@contextmanager
def ray_session(address: str | None = None, num_cpus: int | None = None, log_to_driver: bool | None = None):
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
