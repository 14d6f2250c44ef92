"""`sfv models fetch --robot g1`: extraction with hash checks, the cache, and its one-line errors.

The real fetch downloads a 14 MB wheel; these tests build a small fake wheel with the mjlab
layout in tmp_path (and the pinned digests of its own bytes), so they need no network.
"""
import hashlib
import os
import zipfile
from pathlib import Path

import pytest

from actors.character import g1_model
from learner.errors import SfvError
from services.cli import main
from services.robots import fetch
from services.robots.fetch import extract_robot_from_wheel, fetch_robot

CONTENTS = {"g1.xml": b"<mujoco/>", "assets/pelvis.STL": b"solid pelvis", g1_model.LICENSE_FILE: b"Apache-2.0"}


@pytest.fixture
def fake_table(monkeypatch):
    """Pin the digests of CONTENTS as the G1's files."""
    table = {name: hashlib.sha256(data).hexdigest() for name, data in CONTENTS.items()}
    monkeypatch.setattr(g1_model, "FILE_SHA256", table)
    g1_model._checked_dir.cache_clear()
    yield table
    g1_model._checked_dir.cache_clear()


def _wheel(path: Path, contents: dict[str, bytes]) -> Path:
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("mjlab/__init__.py", "")
        for name, data in contents.items():
            archive.writestr(g1_model.wheel_member(name), data)
    return path


def test_the_real_table_pins_the_xml_every_mesh_and_the_licence():
    assert g1_model.wheel_member("g1.xml") == "mjlab/asset_zoo/robots/unitree_g1/xmls/g1.xml"
    assert g1_model.wheel_member("LICENSE") == "mjlab-1.6.0.dist-info/licenses/LICENSE"
    meshes = [name for name in g1_model.FILE_SHA256 if name.startswith("assets/")]
    assert len(meshes) == 35 and all(name.endswith(".STL") for name in meshes)
    assert all(len(digest) == 64 and int(digest, 16) >= 0 for digest in g1_model.FILE_SHA256.values())


def test_extract_writes_the_verified_files(tmp_path, fake_table):
    wheel = _wheel(tmp_path / "mjlab.whl", CONTENTS)
    xml = extract_robot_from_wheel(wheel, tmp_path / "cache")
    assert xml == tmp_path / "cache" / "g1.xml"
    for name, data in CONTENTS.items():
        assert (tmp_path / "cache" / name).read_bytes() == data
    assert g1_model.damaged_files(tmp_path / "cache") == []
    assert g1_model.model_dir(tmp_path / "cache") == (tmp_path / "cache").resolve()


def test_a_tampered_member_is_a_one_line_error_and_writes_nothing(tmp_path, fake_table):
    wheel = _wheel(tmp_path / "mjlab.whl", {**CONTENTS, "assets/pelvis.STL": b"solid tampered"})
    with pytest.raises(SfvError, match="SHA-256") as error:
        extract_robot_from_wheel(wheel, tmp_path / "cache")
    message = str(error.value)
    assert "\n" not in message and "mjlab.whl" in message and "pelvis.STL" in message
    assert not (tmp_path / "cache").exists()


def test_a_missing_member_is_named(tmp_path, fake_table):
    wheel = _wheel(tmp_path / "mjlab.whl", {k: v for k, v in CONTENTS.items() if k != "g1.xml"})
    with pytest.raises(SfvError, match="wheel has no mjlab/asset_zoo/robots/unitree_g1/xmls/g1.xml"):
        extract_robot_from_wheel(wheel, tmp_path / "cache")


def test_a_missing_cache_is_a_one_line_hint(tmp_path, fake_table):
    with pytest.raises(SfvError) as error:
        g1_model.model_dir(tmp_path / "nothing")
    message = str(error.value)
    assert "\n" not in message and "run `sfv models fetch --robot g1`" in message


def test_a_tampered_cached_file_is_refused_at_load_and_fetched_again(tmp_path, fake_table, monkeypatch):
    cache = tmp_path / "cache"
    extract_robot_from_wheel(_wheel(tmp_path / "mjlab.whl", CONTENTS), cache)
    (cache / "assets" / "pelvis.STL").write_bytes(b"solid tampered")
    with pytest.raises(SfvError) as error:
        g1_model.model_dir(cache)
    assert "\n" not in str(error.value) and "pelvis.STL" in str(error.value) and "--force" in str(error.value)
    downloads = []

    def fake_download(into, requirement):
        downloads.append(requirement)
        return _wheel(Path(into) / "mjlab-1.6.0-py3-none-any.whl", CONTENTS)

    monkeypatch.setattr(fetch, "download_wheel", fake_download)
    assert fetch_robot("g1", cache) == cache / "g1.xml"
    assert downloads == ["mjlab==1.6.0"]
    assert (cache / "assets" / "pelvis.STL").read_bytes() == CONTENTS["assets/pelvis.STL"]
    assert fetch_robot("g1", cache) == cache / "g1.xml"  # a good cache: no download
    assert downloads == ["mjlab==1.6.0"]


def test_cli_fetch_offline_fails_in_one_line_with_exit_2(tmp_path, monkeypatch, capsys):
    empty = tmp_path / "no-wheels"
    empty.mkdir()
    monkeypatch.setenv("PIP_NO_INDEX", "1")
    monkeypatch.setenv("PIP_FIND_LINKS", str(empty))
    monkeypatch.setenv("PIP_CONFIG_FILE", os.devnull)
    assert main(["models", "fetch", "--robot", "g1", "--robot-dir", str(tmp_path / "cache")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("sfv: pip download mjlab==1.6.0 failed") and err.count("\n") == 1
    assert not (tmp_path / "cache").exists()
