"""The peer process (pybullet's DeepMimic env in a child interpreter) and its clean skip."""
from __future__ import annotations

import importlib.util
import subprocess
import sys

import pytest

from services.bench.config import BenchConfig
from services.bench.peer_suite import PeerProcess, PeerUnavailable, run_peer_suite

pytestmark = pytest.mark.integration


def peer_packages_present() -> bool:
    return all(importlib.util.find_spec(name) is not None for name in ("gym", "pybullet_envs", "mpi4py"))


@pytest.mark.skipif(not peer_packages_present(), reason="the `peer` extra (gym 0.26.2, pybullet, mpi4py) is not installed")
def test_peer_process_steps_the_deepmimic_env_at_1200hz():
    peer = PeerProcess(sys.executable, 1200.0, action_noise=0.1, seed=0)
    try:
        assert peer.info["substeps"] == 40  # 1.2 kHz physics, 30 Hz policy
        assert peer.info["action_dim"] == 36
        assert peer.info["gym"] == "0.26.2"
        rates = peer.rate(0.2)
        assert rates.wall > 0 and rates.cpu > 0
    finally:
        peer.close()
    assert peer.proc.returncode == 0


@pytest.fixture
def bare_python(tmp_path):
    """A real interpreter without pybullet_envs: a fresh venv that does not see site-packages."""
    venv = tmp_path / "bare"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    return str(venv / "bin" / "python")


def test_peer_suite_skips_with_a_clear_message_without_pybullet_envs(bare_python):
    with pytest.raises(PeerUnavailable, match="ModuleNotFoundError"):
        PeerProcess(bare_python, 240.0, action_noise=0.1, seed=0)
    result = run_peer_suite(BenchConfig.quick_defaults(suites=("peer",), peer_python=bare_python), log=lambda m: None)
    assert result.skipped is not None
    assert bare_python in result.skipped and "sfv[peer]" in result.skipped
    assert "metrics" not in result.to_dict()


def test_a_peer_that_dies_is_reported_with_its_last_words(tmp_path):
    interpreter = tmp_path / "dying-python"
    interpreter.write_text("#!/bin/sh\necho 'probe broke: out of luck' >&2\nexit 3\n")
    interpreter.chmod(0o755)
    with pytest.raises(PeerUnavailable, match=r"exit code 3\): probe broke: out of luck"):
        PeerProcess(str(interpreter), 240.0, action_noise=0.1, seed=0)
