"""Shared fixtures: a real redis-server, the ../shared folder (skips cleanly when absent)."""
from __future__ import annotations

from pathlib import Path

import pytest

from tests.redis_fixture import redis_server, redis_url  # noqa: F401  (fixtures)

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"


def load_clip(name: str):
    """A DeepMimic clip from pybullet_data (the test skips where the package is absent)."""
    pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")
    from actors.motion.formats.io import load_motion

    return load_motion(f"deepmimic:{name}")


@pytest.fixture(scope="session")
def walk_clip():
    return load_clip("walk")


@pytest.fixture(scope="session")
def shared_humanoid():
    from actors.character.humanoid3d import Humanoid

    return Humanoid()


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    if not SHARED.is_dir():
        pytest.skip("../shared absent: this test needs the shared data folder")
    return SHARED


@pytest.fixture(scope="session")
def models_dir() -> Path:
    """BlazePose models: ../shared's copy for development, else the `sfv models fetch` cache."""
    from services.pose.models import DETECTOR_FILE, LANDMARK_FILE, cached_models_ok, default_models_dir

    shared_models = SHARED / "models" / "blazepose"
    if (shared_models / DETECTOR_FILE).is_file() and (shared_models / LANDMARK_FILE).is_file():
        return shared_models
    if cached_models_ok(default_models_dir()):
        return default_models_dir()
    pytest.skip("BlazePose models absent (../shared absent and `sfv models fetch` not run)")
