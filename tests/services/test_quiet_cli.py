"""Quiet by default: a Ray training's terminal shows its result (and sfv's own lines), the
library chatter (gRPC fork notices, Ray's banners) goes to RUN/sfv.log; `--verbose` shows it
and lets Ray forward its workers' output."""
from __future__ import annotations

import json
import logging
import os
import subprocess
import sys

import pytest

from services import console
from tests.conftest import REPO

def _train(out, *extra):
    env = {k: v for k, v in os.environ.items() if not k.startswith("GRPC_") and k != console.VERBOSE_ENV}
    cmd = [sys.executable, "-m", "services.cli", "train", "--motion", "deepmimic:walk", "--runner", "ray", "--workers", "1",
           "--envs-per-worker", "2", "--samples", "64", "--batch-size", "64", "--eval-every", "0", "--quiet",
           "--out", str(out), *extra]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=600, env=env, cwd=REPO)


@pytest.mark.integration
def test_a_ray_training_prints_its_result_and_logs_the_chatter(tmp_path):
    pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")
    done = _train(tmp_path / "run")
    assert done.returncode == 0, done.stderr[-2000:]
    lines = [line for line in (done.stdout + done.stderr).splitlines() if line.strip()]
    assert len(lines) == 1 and json.loads(lines[0])["samples"] == 64, lines[:20]
    log = (tmp_path / "run" / console.LOG_FILE).read_text()
    assert "Ray workers' output:" in log and "Started a local Ray instance" in log


def test_verbose_shows_library_records_and_forwards_worker_output(capsys, monkeypatch):
    from services.ray_session import _forward_worker_output

    monkeypatch.delenv(console.VERBOSE_ENV, raising=False)
    try:
        console.configure(verbose=False)
        assert _forward_worker_output(None) is False
        logging.getLogger("some_library").warning("library chatter")
        assert "library chatter" not in capsys.readouterr().err
        console.configure(verbose=True)
        assert _forward_worker_output(None) is True and _forward_worker_output(False) is False
        logging.getLogger("some_library").info("library detail")
        assert "library detail" in capsys.readouterr().err
    finally:
        os.environ.pop(console.VERBOSE_ENV, None)  # set by configure itself, not through monkeypatch
        console.configure(verbose=False)


def test_own_warnings_reach_the_terminal_library_records_the_log_file(tmp_path, capsys):
    try:
        console.configure(verbose=False)
        logging.getLogger("sfv.test").warning("one-line warning")
        logging.getLogger("some_library").warning("library chatter")
        logging.getLogger("some_library").info("library detail")
        path = console.attach_log_file(tmp_path)
        logging.getLogger("another_library").info("after attach")
        err = capsys.readouterr().err
        assert "one-line warning" in err and "library" not in err
        log = path.read_text()
        assert all(text in log for text in ("one-line warning", "library chatter", "library detail", "after attach"))
    finally:
        console.configure(verbose=False)
