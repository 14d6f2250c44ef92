"""The distillation dataset on disk: npz chunks plus a manifest (004 §3.3, issue 16 item 2).

Layout of a dataset directory:

    DIR/chunk_00000.npz ...   one clip's consecutive steps per chunk, fields below
    DIR/manifest.json         written last: its presence means the dataset is complete

Fields, one row per control step of an expert rollout with action noise:
- `proprio` (196,) float32: s_t, the decoder's input (`actors/envs/tasks/proprioception.py`);
- `future` (565,) float32: the next 5 reference states relative to the character, the
  encoder's input (`actors/envs/tasks/future_reference.py`);
- `mean_targets` (28,) float32: PD targets (rad) of the expert's mean action, the regression target;
- `applied_targets` (28,) float32: PD targets of the noisy action actually applied;
- `reward` float32 (the imitation reward of the step), `clip` int16 (index into the manifest's
  `clips`), `episode` int32 (unique within the clip), `step` int32 (within the episode),
  `row` int32 (reference table row of s_t).
Rows of one episode are consecutive and in step order, never split across chunks.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from actors.envs.tasks.future_reference import FUTURE_DIM
from actors.envs.tasks.proprioception import PROPRIO_DIM
from actors.character.humanoid3d import HUMANOID3D
from learner.atomic_io import atomic_output, atomic_write_json
from learner.errors import SfvError

MANIFEST = "manifest.json"
FORMAT = "sfv-motor-dataset"
VERSION = 1
FIELDS: dict[str, tuple[str, tuple[int, ...]]] = {
    "proprio": ("float32", (PROPRIO_DIM,)),
    "future": ("float32", (FUTURE_DIM,)),
    "mean_targets": ("float32", (HUMANOID3D.nu,)),  # the experts' character's actuators
    "applied_targets": ("float32", (HUMANOID3D.nu,)),
    "reward": ("float32", ()),
    "clip": ("int16", ()),
    "episode": ("int32", ()),
    "step": ("int32", ()),
    "row": ("int32", ()),
}


def chunk_name(index: int) -> str:
    return f"chunk_{index:05d}.npz"


def check_chunk(arrays: dict, where: str) -> int:
    """The chunk's row count after checking every field's presence, dtype and shape."""
    missing = [name for name in FIELDS if name not in arrays]
    if missing:
        raise SfvError(f"{where}: missing fields {missing}")
    rows = len(arrays["proprio"])
    for name, (dtype, shape) in FIELDS.items():
        array = arrays[name]
        if array.dtype != np.dtype(dtype) or array.shape != (rows, *shape):
            raise SfvError(f"{where}: field {name} is {array.dtype}{array.shape}, expected {dtype}{(rows, *shape)}")
    return rows


def write_chunk(path: Path, arrays: dict) -> int:
    """One chunk, written atomically (temp name, then rename); returns its rows."""
    rows = check_chunk(arrays, str(path))
    with atomic_output(path) as tmp, open(tmp, "wb") as f:
        np.savez(f, **{name: arrays[name] for name in FIELDS})
    return rows


def read_chunk(path: Path) -> dict[str, np.ndarray]:
    try:
        with np.load(path, allow_pickle=False) as npz:
            arrays = {name: npz[name] for name in npz.files}
    except (OSError, ValueError, EOFError) as exc:
        raise SfvError(f"{path}: unreadable dataset chunk ({type(exc).__name__}: {exc})") from None
    check_chunk(arrays, str(path))
    return arrays


def write_manifest(directory: Path, clips: list[str], chunks: list[dict], extra: dict) -> dict:
    """manifest.json (atomically, last): clips, chunk list (file, clip, steps, episodes), field shapes, sizes."""
    directory = Path(directory)
    manifest = {"format": FORMAT, "version": VERSION, "clips": list(clips),
                "fields": {name: {"dtype": dtype, "shape": list(shape)} for name, (dtype, shape) in FIELDS.items()},
                "chunks": chunks, "steps": int(sum(c["steps"] for c in chunks)),
                "steps_per_clip": {clip: int(sum(c["steps"] for c in chunks if c["clip"] == i)) for i, clip in enumerate(clips)},
                "bytes": int(sum((directory / c["file"]).stat().st_size for c in chunks)), **extra}
    atomic_write_json(directory / MANIFEST, manifest, sort_keys=True)
    return manifest


def read_manifest(directory: Path) -> dict:
    path = Path(directory) / MANIFEST
    if not path.is_file():
        raise SfvError(f"{directory}: not a motor dataset (no {MANIFEST}; an interrupted recording leaves none)")
    try:
        manifest = json.loads(path.read_text())
    except ValueError as exc:
        raise SfvError(f"{path}: unreadable manifest ({exc})") from None
    if manifest.get("format") != FORMAT or manifest.get("version") != VERSION:
        raise SfvError(f"{path}: not a {FORMAT} version {VERSION} manifest")
    return manifest


def load_dataset(directory: Path, exclude_clips: tuple[str, ...] = ()) -> tuple[dict[str, np.ndarray], dict]:
    """Every field concatenated over the chunks (those of `exclude_clips` left out), and the manifest."""
    directory = Path(directory)
    manifest = read_manifest(directory)
    unknown = [clip for clip in exclude_clips if clip not in manifest["clips"]]
    if unknown:
        raise SfvError(f"{directory}: clips {unknown} are not in the dataset (it holds {manifest['clips']})")
    skipped = {manifest["clips"].index(clip) for clip in exclude_clips}
    parts: dict[str, list] = {name: [] for name in FIELDS}
    for chunk in manifest["chunks"]:
        if chunk["clip"] in skipped:
            continue
        arrays = read_chunk(directory / chunk["file"])
        if len(arrays["proprio"]) != chunk["steps"]:
            raise SfvError(f"{directory / chunk['file']}: {len(arrays['proprio'])} rows, the manifest says {chunk['steps']}")
        for name in FIELDS:
            parts[name].append(arrays[name])
    if not parts["proprio"]:
        raise SfvError(f"{directory}: no steps left to load")
    return {name: np.concatenate(values) for name, values in parts.items()}, manifest
