"""What the terminal shows: progress bars, results and sfv's own one-line warnings.

Library chatter (Ray's banners, gRPC's C-core notices, Python warnings such as numpy's) goes to
the run's log file (`RUN/sfv.log`, `attach_log_file`) instead; records that come before a
command knows its run directory are kept in memory and written there once it does.
`configure(verbose=True)` (`sfv --verbose`) shows everything on the terminal as well, and
lets Ray forward its workers' output (`services/ray_session.py` reads `is_verbose`).

Native library output (C/C++ writing to fd 2) follows the same way (`services/native_output.py`).

`configure` runs in the `sfv` entry point before anything imports gRPC or Ray: gRPC reads its
settings from the environment once, when it loads, and Ray's processes inherit them.
"""
from __future__ import annotations

import logging
import os
import sys
from collections import deque
from pathlib import Path

VERBOSE_ENV = "SFV_VERBOSE"
LOG_FILE = "sfv.log"
# Loggers of this project: their warnings reach the terminal; everything else only the log file.
OWN_LOGGERS = ("sfv", "services", "actors", "learner", "bench", "proto")
# gRPC C-core: errors only (its fork_posix.cc "skipping fork() handlers" notices are INFO); no fork
# handlers (sfv's own subprocesses are spawned, Ray's are started by the raylet).
QUIET_GRPC_ENV = {"GRPC_VERBOSITY": "ERROR", "GRPC_ENABLE_FORK_SUPPORT": "false"}
_FORMAT = "%(asctime)s %(levelname)s %(name)s: %(message)s"


class _CurrentStderr(logging.StreamHandler):
    """A handler on whatever `sys.stderr` is when a record comes (tests swap it)."""

    def __init__(self):
        super().__init__(sys.stderr)

    def emit(self, record: logging.LogRecord) -> None:
        self.stream = sys.stderr
        super().emit(record)


class _Pending(logging.Handler):
    """The newest records logged before the run's log file is known."""

    def __init__(self, keep: int = 10_000):
        super().__init__(logging.INFO)
        self.records: deque[logging.LogRecord] = deque(maxlen=keep)

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


class _OwnRecords(logging.Filter):
    def filter(self, record: logging.LogRecord) -> bool:
        return record.name.split(".")[0] in OWN_LOGGERS


_installed: list[logging.Handler] = []
_pending: _Pending | None = None


def is_verbose() -> bool:
    return os.environ.get(VERBOSE_ENV, "") not in ("", "0")


def configure(verbose: bool = False) -> None:
    """Route logging and library settings for one `sfv` command (idempotent)."""
    global _pending
    if verbose:
        os.environ[VERBOSE_ENV] = "1"
    else:
        for name, value in QUIET_GRPC_ENV.items():
            os.environ.setdefault(name, value)
    root = logging.getLogger()
    for handler in _installed:
        root.removeHandler(handler)
        handler.close()
    _installed.clear()
    terminal = _CurrentStderr()
    terminal.setFormatter(logging.Formatter("%(levelname)s %(name)s: %(message)s"))
    if is_verbose():
        terminal.setLevel(logging.INFO)
    else:
        terminal.setLevel(logging.WARNING)
        terminal.addFilter(_OwnRecords())
    _pending = _Pending()  # library records wait here for the run's log file
    for handler in (terminal, _pending):
        root.addHandler(handler)
        _installed.append(handler)
    root.setLevel(min(root.level if root.level != logging.NOTSET else logging.WARNING, logging.INFO))
    logging.captureWarnings(True)  # numpy's and other libraries' warnings become records too


def attach_log_file(directory: str | os.PathLike) -> Path:
    """Write every record (INFO and up, libraries included) to DIRECTORY/sfv.log from now on,
    with those logged so far in this command first."""
    global _pending
    path = Path(directory) / LOG_FILE
    path.parent.mkdir(parents=True, exist_ok=True)
    handler = logging.FileHandler(path, encoding="utf-8")
    handler.setFormatter(logging.Formatter(_FORMAT))
    handler.setLevel(logging.INFO)
    root = logging.getLogger()
    if _pending is not None:
        for record in _pending.records:
            handler.handle(record)
        root.removeHandler(_pending)
        _installed.remove(_pending)
        _pending.close()
        _pending = None
    root.addHandler(handler)
    _installed.append(handler)
    from services.native_output import ROUTE

    ROUTE.follow(path)  # native library output (fd 2) too, when the entry point routes it
    return path
