"""The run directory: resolved config, metrics.jsonl, TensorBoard events, checkpoints."""
from __future__ import annotations

import dataclasses

import json
from pathlib import Path

from learner.atomic_io import atomic_write_json, atomic_write_text
from learner.errors import SfvError

CONFIG_FILE = "config.json"
METRICS_FILE = "metrics.jsonl"


def checkpoint_files(run_dir: Path) -> list[Path]:
    """Every `checkpoint_<iteration>.pt` in the run directory, oldest first, valid or not (temp files excluded)."""
    from learner.checkpoint import CHECKPOINT_NAME

    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        return []
    named = [(int(m.group(1)), entry) for entry in run_dir.iterdir() if (m := CHECKPOINT_NAME.match(entry.name)) and entry.is_file()]
    return [entry for _, entry in sorted(named)]


def remove_stale_temp_files(run_dir: Path) -> list[str]:
    """Delete `.<name>.<random>.tmp` files that a killed process left mid atomic write; returns their names."""
    removed = []
    for path in Path(run_dir).glob(".*.tmp"):
        if path.is_file():
            path.unlink(missing_ok=True)
            removed.append(path.name)
    return removed


def read_run_config(run_dir: str | Path):
    """The run's TrainConfig from config.json alone (no checkpoint, no torch)."""
    from services.training.config import TrainConfig

    path = Path(run_dir) / CONFIG_FILE
    if not path.is_file():
        raise SfvError(f"{run_dir}: not a run directory (no {CONFIG_FILE})")
    try:
        return TrainConfig.from_dict(json.loads(path.read_text()))
    except (ValueError, TypeError) as exc:
        raise SfvError(f"{path}: unreadable run config ({type(exc).__name__}: {exc})") from None


def trained_samples(run_dir: str | Path) -> int | None:
    """The samples the run's newest valid checkpoint holds; None for a run with none (nothing to resume)."""
    from learner.checkpoint import latest_checkpoint, load_checkpoint

    latest = latest_checkpoint(run_dir)
    return None if latest is None else int(load_checkpoint(latest)["samples"])


BEST_CHECKPOINT = "best.pt"  # the policy of the best periodic evaluation so far (the driver keeps it)
CHECKPOINT_CHOICES = ("best", "latest")


def run_checkpoint(run_dir: str | Path, which: str = "best") -> Path:
    """The checkpoint a run's policy is read from: `best.pt` (the highest evaluation so far,
    what `sfv eval`, `render` and `export` use by default) when the run has one, else the newest;
    `which="latest"` always the newest."""
    if which not in CHECKPOINT_CHOICES:
        raise SfvError(f"--checkpoint must be one of {', '.join(CHECKPOINT_CHOICES)}, got {which!r}")
    best = Path(run_dir) / BEST_CHECKPOINT
    if which == "best" and best.is_file():
        return best
    checkpoints = checkpoint_files(Path(run_dir))
    if not checkpoints:
        raise SfvError(f"{run_dir}: no checkpoint yet")
    return checkpoints[-1]


def load_run(run_dir: str | Path, which: str = "best"):
    """The run's TrainConfig and the policy weights (numpy) of `run_checkpoint(run_dir, which)`."""
    import numpy as np

    from learner.checkpoint import load_checkpoint

    config = read_run_config(run_dir)
    path = run_checkpoint(run_dir, which)
    # Verified: a corrupt or tampered file is an error, never silently an older policy.
    payload = load_checkpoint(path)
    if not isinstance(payload.get("policy_weights"), dict):
        raise SfvError(f"{path}: checkpoint holds no policy weights")
    weights = {k: v.numpy() if hasattr(v, "numpy") else np.asarray(v) for k, v in payload["policy_weights"].items()}
    if payload.get("residual_force_scale") is not None:  # a decaying help: play the policy at the strength it was trained at
        config.env = dataclasses.replace(config.env, residual_force_scale=float(payload["residual_force_scale"]))
    return config, weights


def write_json_atomic(path: Path, obj) -> None:
    """Run-directory JSON (config.json): sorted keys, so configs diff cleanly."""
    atomic_write_json(path, obj, sort_keys=True)


class MetricsLog:
    """One JSON line per iteration, plus the same scalars as TensorBoard events.

    `resumed_at_samples`: the run continues from a checkpoint taken at that sample count;
    TensorBoard events logged after it by the interrupted process are purged.
    """

    def __init__(self, run_dir: Path, resumed_at_samples: int | None = None):
        self.path = run_dir / METRICS_FILE
        self._tb = None
        try:
            from torch.utils.tensorboard import SummaryWriter

            purge = None if resumed_at_samples is None else resumed_at_samples + 1
            self._tb = SummaryWriter(str(run_dir / "tb"), purge_step=purge)
        except ImportError:  # tensorboard is a dependency; keep training if it is broken
            pass

    def write(self, record: dict) -> None:
        with open(self.path, "a") as f:
            f.write(json.dumps(record, sort_keys=True) + "\n")
        if self._tb is not None:
            step = record["samples"]
            for key, value in record.items():
                if isinstance(value, (int, float)) and key not in ("samples",):
                    self._tb.add_scalar(key if "/" in key else f"charts/{key}", value, step)
            self._tb.flush()

    def close(self) -> None:
        if self._tb is not None:
            self._tb.close()


def drop_metrics_after(run_dir: Path, samples: int) -> int:
    """Rewrite metrics.jsonl without the rows past `samples` (iterations a killed run did after
    its last checkpoint, redone on resume); returns how many rows went."""
    path = Path(run_dir) / METRICS_FILE
    if not path.exists():
        return 0
    lines = path.read_text().splitlines()
    kept = []
    for line in lines:
        try:
            row = json.loads(line)
        except json.JSONDecodeError:
            continue  # a line cut by the kill
        if row.get("samples", 0) <= samples:
            kept.append(line)
    if len(kept) != len(lines):
        atomic_write_text(path, "".join(line + "\n" for line in kept))
    return len(lines) - len(kept)


def read_metrics(run_dir: Path) -> list[dict]:
    path = Path(run_dir) / METRICS_FILE
    if not path.exists():
        return []
    rows = []
    for line in path.read_text().splitlines():
        try:
            rows.append(json.loads(line))
        except json.JSONDecodeError:
            continue  # a line cut by a kill; the next iteration writes whole lines again
    return rows
