"""Native output, routed: what C/C++ libraries write to file descriptor 2 (TFLite's "Created
TensorFlow Lite XNNPACK delegate" notice, MuJoCo's and gRPC's C-core messages) goes where library
records go, the run's log file, instead of the terminal.

`NativeStderr.start()` (the `sfv` entry point, unless `--verbose`) points fd 2 at a capture file and
keeps Python's `sys.stderr` on the terminal (a duplicate of the original fd 2): sfv's own lines,
progress bars and tracebacks still show. `follow(path)` (when a command knows its run directory,
`console.attach_log_file`) appends what was captured so far to that log and points fd 2 at it, so
a crash's last words land there too. `stop(failed)` restores fd 2; what is still captured becomes
log records, and is shown on the terminal as well when the command failed. Environment variables
cannot do this: TFLite's minimal logger ignores TF_CPP_MIN_LOG_LEVEL and GLOG_minloglevel.
"""
from __future__ import annotations

import logging
import os
import sys
import tempfile

STDERR_FD = 2
log = logging.getLogger("sfv.native")


class NativeStderr:
    def __init__(self):
        self._saved_fd: int | None = None
        self._capture = None  # the temporary file fd 2 writes to until a log file is known
        self._python_stderr = None

    @property
    def active(self) -> bool:
        return self._saved_fd is not None

    def start(self) -> bool:
        """Route fd 2 (only for a real terminal stream: a test's captured sys.stderr is left alone)."""
        if self.active or sys.stderr is not sys.__stderr__ or sys.stderr is None:
            return False
        try:
            if sys.stderr.fileno() != STDERR_FD:
                return False
        except (AttributeError, OSError, ValueError):
            return False
        sys.stderr.flush()
        self._saved_fd = os.dup(STDERR_FD)
        self._capture = tempfile.TemporaryFile()
        os.dup2(self._capture.fileno(), STDERR_FD)
        self._python_stderr = sys.stderr
        sys.stderr = open(self._saved_fd, "w", buffering=1, encoding=self._python_stderr.encoding,
                          errors="backslashreplace", closefd=False)
        return True

    def _drain(self) -> str:
        """What the capture file holds, emptied."""
        if self._capture is None:
            return ""
        self._capture.flush()
        self._capture.seek(0)
        text = self._capture.read().decode("utf-8", "backslashreplace")
        self._capture.seek(0)
        self._capture.truncate()
        return text

    def follow(self, log_path: os.PathLike) -> None:
        """From now on fd 2 appends to `log_path`, after the lines captured so far (as records)."""
        if not self.active:
            return
        self._log_lines(self._drain())
        log_fd = os.open(log_path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        os.dup2(log_fd, STDERR_FD)
        os.close(log_fd)
        self._capture.close()
        self._capture = None

    def stop(self, failed: bool = False) -> None:
        """fd 2 back on the terminal; leftovers logged (and shown when the command failed)."""
        if not self.active:
            return
        sys.stderr.flush()
        os.dup2(self._saved_fd, STDERR_FD)
        sys.stderr.close()
        sys.stderr = self._python_stderr
        os.close(self._saved_fd)
        self._saved_fd = None
        text = self._drain()
        if self._capture is not None:
            self._capture.close()
            self._capture = None
        self._log_lines(text)
        if failed and text.strip():
            sys.stderr.write(text if text.endswith("\n") else text + "\n")

    @staticmethod
    def _log_lines(text: str) -> None:
        for line in text.splitlines():
            if line.strip():
                log.info("%s", line)


ROUTE = NativeStderr()  # the process's one fd 2
