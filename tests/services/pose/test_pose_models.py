"""Model acquisition: wheel extraction, hash checks, lookup, and pip failure.

The real `sfv models fetch` downloads a 36 MB wheel, too slow and flaky for CI; these
tests build zips that mimic the wheel's layout instead, and make pip fail offline.
"""
import hashlib
import os
import zipfile
from pathlib import Path

import pytest

from learner.errors import SfvError
from services.cli import main
from services.pose import models
from services.pose.models import (
    DETECTOR_FILE,
    LANDMARK_FILE,
    LANDMARK_ONNX_FILE,
    WHEEL_MEMBERS,
    default_models_dir,
    extract_models_from_wheel,
    fetch_models,
    resolve_model_files,
)

SHARED = Path(__file__).resolve().parents[3].parent / "shared"
SHARED_MODELS = SHARED / "models" / "blazepose"


@pytest.fixture
def shared_models():
    if not (SHARED_MODELS / DETECTOR_FILE).is_file() or not (SHARED_MODELS / LANDMARK_FILE).is_file():
        pytest.skip("../shared absent")
    return SHARED_MODELS


@pytest.fixture
def offline_pip(monkeypatch, tmp_path):
    """Make `pip download` fail fast without the network: no index, an empty find-links dir."""
    empty = tmp_path / "no-wheels"
    empty.mkdir()
    monkeypatch.setenv("PIP_NO_INDEX", "1")
    monkeypatch.setenv("PIP_FIND_LINKS", str(empty))
    monkeypatch.setenv("PIP_CONFIG_FILE", os.devnull)


def _fake_members():
    contents = {DETECTOR_FILE: b"detector bytes", LANDMARK_FILE: b"landmark bytes"}
    members = {name: (f"mediapipe/modules/x/{name}", hashlib.sha256(data).hexdigest()) for name, data in contents.items()}
    return contents, members


def _wheel(path: Path, files: dict[str, bytes]) -> Path:
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("mediapipe/__init__.py", "")
        for member, data in files.items():
            archive.writestr(member, data)
    return path


def test_extract_writes_verified_members(tmp_path):
    contents, members = _fake_members()
    wheel = _wheel(tmp_path / "mp.whl", {members[n][0]: contents[n] for n in contents})
    files = extract_models_from_wheel(wheel, tmp_path / "cache", members)
    assert files.detector.read_bytes() == contents[DETECTOR_FILE]
    assert files.landmark.read_bytes() == contents[LANDMARK_FILE]
    assert sorted(p.name for p in (tmp_path / "cache").iterdir()) == sorted(contents)


def test_hash_mismatch_is_an_error_and_writes_nothing(tmp_path):
    contents, members = _fake_members()
    wheel = _wheel(tmp_path / "mp.whl", {members[DETECTOR_FILE][0]: contents[DETECTOR_FILE],
                                         members[LANDMARK_FILE][0]: b"tampered"})
    with pytest.raises(SfvError, match="SHA-256") as error:
        extract_models_from_wheel(wheel, tmp_path / "cache", members)
    assert "mp.whl" in str(error.value) and "\n" not in str(error.value)
    assert not (tmp_path / "cache").exists()


def test_missing_member_and_non_zip_are_errors(tmp_path):
    contents, members = _fake_members()
    wheel = _wheel(tmp_path / "mp.whl", {members[DETECTOR_FILE][0]: contents[DETECTOR_FILE]})
    with pytest.raises(SfvError, match="wheel has no mediapipe/modules/x/pose_landmark_full.tflite"):
        extract_models_from_wheel(wheel, tmp_path / "cache", members)
    not_zip = tmp_path / "bad.whl"
    not_zip.write_bytes(b"PK? no")
    with pytest.raises(SfvError, match="not a readable wheel"):
        extract_models_from_wheel(not_zip, tmp_path / "cache", members)


@pytest.mark.shared
def test_real_digests_match_the_shared_copies_in_wheel_layout(tmp_path, shared_models):
    """../shared holds the wheel's files byte for byte; a zip laid out like the wheel passes the real check."""
    wheel = _wheel(tmp_path / "mediapipe-0.10.21-py3-none-any.whl",
                   {member: (shared_models / name).read_bytes() for name, (member, _) in WHEEL_MEMBERS.items()})
    files = extract_models_from_wheel(wheel, tmp_path / "cache")
    assert files.detector.read_bytes() == (shared_models / DETECTOR_FILE).read_bytes()
    assert files.landmark.read_bytes() == (shared_models / LANDMARK_FILE).read_bytes()


def test_pip_failure_is_a_one_line_error(tmp_path, offline_pip):
    with pytest.raises(SfvError, match=r"^pip download mediapipe==0\.10\.21 failed: ") as error:
        fetch_models(tmp_path / "cache")
    assert "\n" not in str(error.value)
    assert not (tmp_path / "cache").exists()


def test_cli_fetch_reports_failure_with_exit_2(tmp_path, offline_pip, capsys):
    assert main(["models", "fetch", "--pose-models", str(tmp_path / "cache")]) == 2
    assert capsys.readouterr().err.startswith("sfv: pip download mediapipe==0.10.21 failed")


@pytest.mark.shared
def test_fetch_skips_download_when_cache_is_valid(tmp_path, offline_pip, shared_models):
    cache = tmp_path / "cache"
    cache.mkdir()
    for name in WHEEL_MEMBERS:
        (cache / name).write_bytes((shared_models / name).read_bytes())
    assert fetch_models(cache).detector == cache / DETECTOR_FILE  # pip would fail if it were run
    (cache / LANDMARK_FILE).write_bytes(b"corrupted")
    with pytest.raises(SfvError, match="pip download"):
        fetch_models(cache)


def test_models_dir_comes_from_env_then_user_cache(monkeypatch, tmp_path):
    monkeypatch.setenv(models.MODELS_ENV, str(tmp_path))
    assert default_models_dir() == tmp_path
    monkeypatch.delenv(models.MODELS_ENV)
    assert default_models_dir().parts[-3:] == ("sfv", "models", "blazepose")


def test_missing_models_name_the_file_and_the_fix(tmp_path):
    with pytest.raises(SfvError, match="pose_detection.tflite: pose model not found; run `sfv models fetch`"):
        resolve_model_files(tmp_path)


def test_landmark_model_falls_back_to_onnx_and_accepts_an_explicit_file(tmp_path):
    for name in (DETECTOR_FILE, LANDMARK_ONNX_FILE, "mine.onnx"):
        (tmp_path / name).write_bytes(b"x")
    assert resolve_model_files(tmp_path).landmark == tmp_path / LANDMARK_ONNX_FILE
    assert resolve_model_files(tmp_path, tmp_path / "mine.onnx").landmark == tmp_path / "mine.onnx"
    (tmp_path / LANDMARK_FILE).write_bytes(b"x")
    assert resolve_model_files(tmp_path).landmark == tmp_path / LANDMARK_FILE
