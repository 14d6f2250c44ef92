"""Real videos from outside the lab for the videos suite, fetched from PyPI wheels and hash-checked.

`../shared` holds two Pose2Sim lab trials (a known camera, one floor, people who stay in place).
The kinds of video a user brings are not there: a walk across metres outdoors, a subject who
enters and leaves, a second person in the scene, a camera at an unknown height. Such a video
reaches this machine the way the pose models do (`services/pose/models.py`): inside a PyPI
wheel, `pip download --no-deps`, the members read with zipfile, checked against the SHA-256 below,
then written atomically into the cache. Nothing of the wheel is imported or installed.

- `sports2d_demo`: the demo of Sports2D (BSD 3-Clause, perfanalytics), 1768 x 994 px, 30 fps,
  230 frames (7.7 s), a park: a woman walks about 5 m from right to left across the frame in
  4.7 s (she enters at the right edge and leaves at the left), while a man jumps on a utility
  box behind and steps down out of sight. This is the "walk filmed in a park" of issue 44.

The name in `sfv bench --suite videos --videos public:NAME` (or `public` for all of them).
"""
from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path

from platformdirs import user_cache_dir

from learner.errors import SfvError


@dataclass(frozen=True)
class PublicVideo:
    """One video inside a PyPI wheel: where it is, its digest, and its licence file."""

    requirement: str
    member: str
    sha256: str
    licence_member: str
    licence_sha256: str

    @property
    def file_name(self) -> str:
        return Path(self.member).name


PUBLIC_VIDEOS: dict[str, PublicVideo] = {
    "sports2d_demo": PublicVideo(
        requirement="sports2d==0.8.34",
        member="Sports2D/Demo/demo.mp4",
        sha256="d9a66417185647b112304b57093f0c180f37a768e6a14daca75ca541f3b78039",
        licence_member="sports2d-0.8.34.dist-info/licenses/LICENSE",
        licence_sha256="7f8a9ede713463b96d261a39c3ec404748c8e4f528c795e5f8cb18898ed944cf",
    ),
}
PREFIX = "public"


def default_videos_dir() -> Path:
    return Path(user_cache_dir("sfv")) / "videos"


def members_of(video: PublicVideo) -> dict[str, tuple[str, str]]:
    """{file name in the folder: (wheel member, SHA-256)}: the video and its LICENSE beside it
    (the suite reads the licence from there)."""
    return {video.file_name: (video.member, video.sha256), "LICENSE": (video.licence_member, video.licence_sha256)}


def cached_ok(folder: Path, video: PublicVideo) -> bool:
    from services.pose.models import sha256_of
    return all((folder / name).is_file() and sha256_of((folder / name).read_bytes()) == digest
               for name, (_, digest) in members_of(video).items())


def fetch_public_video(name: str, videos_dir: Path | None = None, download=None) -> Path:
    """The cached video file of `name`, downloading and verifying its wheel when the cache is
    absent or damaged. `download(into, requirement) -> wheel path` is pip by default."""
    from services.pose.models import copy_verified_members, download_wheel
    if name not in PUBLIC_VIDEOS:
        raise SfvError(f"--videos {PREFIX}:{name}: unknown public video (known: {', '.join(PUBLIC_VIDEOS)})")
    video = PUBLIC_VIDEOS[name]
    folder = (videos_dir or default_videos_dir()) / name
    if not cached_ok(folder, video):
        with tempfile.TemporaryDirectory(prefix="sfv-video-") as tmp:
            wheel = (download or download_wheel)(Path(tmp), video.requirement)
            copy_verified_members(wheel, folder, members_of(video))
    return folder / video.file_name


def resolve_public(spec: str, videos_dir: Path | None = None, download=None) -> list[Path] | None:
    """`public` -> every public video, `public:NAME` -> that one (fetched); None for a path."""
    if spec == PREFIX:
        return [fetch_public_video(name, videos_dir, download) for name in PUBLIC_VIDEOS]
    if spec.startswith(PREFIX + ":"):
        return [fetch_public_video(spec[len(PREFIX) + 1:], videos_dir, download)]
    return None
