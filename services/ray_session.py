"""The one place that starts or joins Ray: training, pose and reconstruction tasks, the
pipeline and the benchmarks all come through here.

A local start is a private single-node Ray (`address="local"`: never a cluster someone else
started on this machine) whose workers can import the project from a checkout (PYTHONPATH in
the runtime env), without the dashboard and without Ray configuring the process's logging.
It is retried once on any failure: on a busy 2-core machine the raylet missed Ray's fixed 30 s
registration deadline (about once in 10 CI runs) and the GCS server its 30 s port-file
deadline (`Timed out waiting for file .../gcs_server_port_...`, seen on a quiet machine too).

Private and fair, so any number of runs can share a machine:
- No fixed ports. `ray.init` leaves the dashboard agent on Ray's fixed port 52365 even without
  the dashboard; the second run's agent then fails to bind, and its raylet (which fate-shares
  with the agent) stopped 28 minutes into a training, killing it. `_ports_chosen_by_the_os`
  asks for port 0 there, as Ray already does for the GCS, raylet, metrics and runtime-env agent.
- Worker niceness 0. Ray starts its workers at nice 15, for a cluster node where they should
  yield to the node's own services. Here the workers *are* the training: beside two
  `--runner processes` trainings (nice 0) a Ray-runner training fell from about 4,200 to 127
  samples/s. At nice 0 every run gets its fair share of the cores, whichever runner it uses.

A local Ray that dies under a run (its raylet killed, the out-of-memory killer) is noticed by
`local_ray_alive` and started again by the runner (`runners/ray_actors.py`).

Quiet by default: the workers' output stays in Ray's session log folder (its path goes to the
run's log file, `services/console.py`) instead of being forwarded to the terminal with Ray's
`(task pid=...)` prefixes; `sfv --verbose` forwards it (`log_to_driver=None` means: as verbose
says).
"""
from __future__ import annotations

import logging
import os
from contextlib import contextmanager
from typing import Iterator
from pathlib import Path

from learner.errors import SfvError
from services.console import is_verbose

_REPO_ROOT = Path(__file__).resolve().parents[1]
LOCAL_START_ATTEMPTS = 4
WORKER_NICENESS = 0  # Ray's default is 15: see the module docstring
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


@contextmanager
def _ports_chosen_by_the_os() -> Iterator[None]:
    """`ray.init` builds its `RayParams` without the dashboard agent's port, whose default is
    the fixed 52365: for this call, that default is 0 (a free port the OS picks). Ray's public
    `ray.init` has no argument for it (Ray 2.60); the class is swapped back right after."""
    from ray._private import parameter

    original = parameter.RayParams

    class RayParamsOnFreePorts(original):
        def __init__(self, *args, **kwargs):
            kwargs.setdefault("dashboard_agent_listen_port", 0)
            super().__init__(*args, **kwargs)

    parameter.RayParams = RayParamsOnFreePorts
    try:
        yield
    finally:
        parameter.RayParams = original


def local_ray_alive() -> bool:
    """Whether this process's local Ray (the one `start_local_ray` started) still has its GCS
    and raylet; True when this process joined a cluster (its health is the cluster's)."""
    from ray._private.worker import global_worker

    node = getattr(global_worker, "node", None)
    processes = getattr(node, "all_processes", None) if node is not None else None
    if not processes:  # joined a cluster, or not started here
        return True
    for kind in ("gcs_server", "raylet"):
        for info in processes.get(kind, ()):
            if info.process.poll() is not None:
                return False
    return True


def start_local_ray(num_cpus: int | None = None, log_to_driver: bool | None = None, attempts: int = LOCAL_START_ATTEMPTS) -> None:
    """A single-node Ray on this machine, retried on any start failure."""
    import ray

    log_to_driver = _forward_worker_output(log_to_driver)
    _quiet_ray_logger()

    python_path = os.pathsep.join(p for p in (str(_REPO_ROOT), os.environ.get("PYTHONPATH", "")) if p)
    for attempt in range(1, attempts + 1):
        try:
            with _ports_chosen_by_the_os():
                ray.init(address="local", num_cpus=num_cpus or os.cpu_count() or 1, include_dashboard=False,
                         configure_logging=False, log_to_driver=log_to_driver, logging_level=logging.WARNING,
                         runtime_env={"env_vars": {"PYTHONPATH": python_path}},
                         _system_config={"worker_niceness": WORKER_NICENESS})
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


def restart_local_ray(num_cpus: int | None = None, log_to_driver: bool | None = None) -> None:
    """Drop what is left of a dead local Ray in this process and start a fresh one."""
    import ray

    ray.shutdown()
    start_local_ray(num_cpus, log_to_driver)


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
