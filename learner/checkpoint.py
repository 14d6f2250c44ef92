"""Atomic, integrity-checked training checkpoints loadable with torch.load(weights_only=True).

File layout: a torch.save'd envelope ``{"format", "version", "sha256", "payload"}`` whose
``payload`` is the torch.save'd bytes of the caller's dict as a uint8 tensor.  torch's zip
reader notices truncation but not flipped bytes inside tensor data, so the SHA-256 over
the inner bytes is what turns a tampered or bit-rotted file into a clear error instead of
silently wrong weights.  Both levels load with ``weights_only=True``, so opening a
checkpoint never runs pickled code.

Payloads may hold tensors, numpy arrays and scalars (stored as tensors / python numbers;
they come back as tensors), str, bool, int, float, None, and dicts/lists/tuples of them.
"""

from __future__ import annotations

import hashlib
import io
import os
import re
from pathlib import Path
from typing import Any

import numpy as np
import torch

from learner.atomic_io import atomic_write_bytes
from learner.errors import SfvError

CHECKPOINT_FORMAT = "sfv-checkpoint"
CHECKPOINT_VERSION = 1
CHECKPOINT_NAME = re.compile(r"^checkpoint_(\d+)\.pt$")


def checkpoint_path(run_dir: str | os.PathLike, iteration: int) -> Path:
    """Canonical file name; zero-padded so names sort like iterations."""
    return Path(run_dir) / f"checkpoint_{iteration:09d}.pt"


def to_storable(value: Any, where: str = "payload") -> Any:
    """Convert numpy values to tensors / python scalars and move tensors to the CPU."""
    if isinstance(value, torch.Tensor):
        return value.detach().cpu()
    if isinstance(value, np.ndarray):
        if value.dtype == object:
            raise TypeError(f"checkpoint {where}: numpy object arrays cannot be stored")
        return torch.from_numpy(np.array(value, copy=True))
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, dict):
        return {key: to_storable(item, f"{where}[{key!r}]") for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        items = [to_storable(item, f"{where}[{index}]") for index, item in enumerate(value)]
        return items if isinstance(value, list) else tuple(items)
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    raise TypeError(f"checkpoint {where}: cannot store a {type(value).__name__}")


def _torch_bytes(obj: Any) -> bytes:
    buffer = io.BytesIO()
    torch.save(obj, buffer)
    return buffer.getvalue()


def save_checkpoint(path: str | os.PathLike, payload: dict[str, Any]) -> Path:
    """Write `payload` (learner state plus caller extras) atomically to `path`."""
    inner = _torch_bytes(to_storable(payload))
    envelope = {
        "format": CHECKPOINT_FORMAT,
        "version": CHECKPOINT_VERSION,
        "sha256": hashlib.sha256(inner).hexdigest(),
        "payload": torch.frombuffer(bytearray(inner), dtype=torch.uint8),
    }
    return atomic_write_bytes(path, _torch_bytes(envelope))


def _corrupt(path: Path, reason: str) -> SfvError:
    reason = " ".join(reason.split())[:200]
    return SfvError(f"{path}: checkpoint is truncated or corrupt ({reason})")


def _verified_payload_bytes(path: Path) -> bytes:
    if not path.is_file():
        raise SfvError(f"{path}: checkpoint not found")
    try:
        envelope = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises RuntimeError, UnpicklingError, EOFError, ... here
        raise _corrupt(path, f"{type(exc).__name__}: {exc}") from exc
    if not isinstance(envelope, dict) or envelope.get("format") != CHECKPOINT_FORMAT:
        raise _corrupt(path, "not an sfv checkpoint envelope")
    if envelope.get("version") != CHECKPOINT_VERSION:
        raise SfvError(f"{path}: checkpoint format version {envelope.get('version')!r} is not supported")
    blob = envelope.get("payload")
    if not isinstance(blob, torch.Tensor) or blob.dtype != torch.uint8:
        raise _corrupt(path, "payload is not a byte tensor")
    data = blob.numpy().tobytes()
    if hashlib.sha256(data).hexdigest() != envelope.get("sha256"):
        raise _corrupt(path, "SHA-256 of the payload does not match")
    return data


def load_checkpoint(path: str | os.PathLike) -> dict[str, Any]:
    """The payload dict saved by `save_checkpoint`, or SfvError naming the file."""
    path = Path(path)
    data = _verified_payload_bytes(path)
    try:
        payload = torch.load(io.BytesIO(data), map_location="cpu", weights_only=True)
    except Exception as exc:
        raise _corrupt(path, f"{type(exc).__name__}: {exc}") from exc
    if not isinstance(payload, dict):
        raise _corrupt(path, f"payload is a {type(payload).__name__}, expected a dict")
    return payload


def latest_checkpoint(run_dir: str | os.PathLike) -> Path | None:
    """Newest complete ``checkpoint_<iteration>.pt`` in `run_dir`, or None.

    Temp files (``*.tmp``) never match the name pattern; a file that fails its integrity
    check is skipped so that resuming falls back to the previous good checkpoint.
    """
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        return None
    candidates = []
    for entry in run_dir.iterdir():
        match = CHECKPOINT_NAME.match(entry.name)
        if match and entry.is_file():
            candidates.append((int(match.group(1)), entry.stat().st_mtime, entry))
    for _, _, path in sorted(candidates, reverse=True):
        try:
            _verified_payload_bytes(path)
        except SfvError:
            continue
        return path
    return None
