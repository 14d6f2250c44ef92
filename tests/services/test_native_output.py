"""Native library output (what C/C++ writes to fd 2) goes to the run's log, not the terminal;
Python's own stderr stays on the terminal; a failed command shows what it captured."""
from __future__ import annotations

import subprocess
import sys

from tests.conftest import REPO

SCRIPT = """
import logging, os, sys
from services import console
from services.native_output import ROUTE
console.configure(verbose=False)
assert ROUTE.start()
os.write(2, b"native before the log\\n")
print("own line", file=sys.stderr)
console.attach_log_file(sys.argv[1])
os.write(2, b"native after the log\\n")
ROUTE.stop(failed=False)
os.write(2, b"native after stop\\n")
"""

FAILING = """
import os, sys
from services.native_output import ROUTE
assert ROUTE.start()
os.write(2, b"native last words\\n")
ROUTE.stop(failed=True)
"""


def _run(script: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", script, *args], capture_output=True, text=True, cwd=REPO, timeout=120)


def test_native_lines_go_to_the_log_and_python_lines_to_the_terminal(tmp_path):
    done = _run(SCRIPT, str(tmp_path))
    assert done.returncode == 0, done.stderr
    assert "own line" in done.stderr and "native after stop" in done.stderr
    assert "native before" not in done.stderr and "native after the log" not in done.stderr
    log = (tmp_path / "sfv.log").read_text()
    assert "native before the log" in log and "native after the log" in log


def test_a_failed_command_shows_what_it_captured():
    done = _run(FAILING)
    assert done.returncode == 0 and "native last words" in done.stderr


def test_the_entry_point_keeps_the_tflite_notice_off_the_terminal(tmp_path):
    """`sfv` itself: a native write during a command is not on its terminal."""
    done = subprocess.run([sys.executable, "-c", "import os, sys; from services.commands import motion; "
                           "motion.run_check = lambda args: os.write(2, b'INFO: Created TensorFlow Lite XNNPACK delegate\\n') and 0; "
                           "from services.cli import main; sys.exit(main(['motion', 'check', 'x']))"],
                          capture_output=True, text=True, cwd=REPO, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "XNNPACK" not in done.stderr
