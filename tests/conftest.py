"""Shared fixtures: a real redis-server, the ../shared folder (skips cleanly when absent)."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from tests.redis_fixture import redis_server, redis_url  # noqa: F401  (fixtures)

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"

# Rendering tests run headless on CPU machines.
os.environ.setdefault("MUJOCO_GL", "osmesa")


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    if not SHARED.is_dir():
        pytest.skip("../shared absent: this test needs the shared data folder")
    return SHARED
