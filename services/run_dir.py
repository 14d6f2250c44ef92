"""The run directory: resolved config, metrics.jsonl, TensorBoard events, checkpoints."""
from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

CONFIG_FILE = "config.json"
METRICS_FILE = "metrics.jsonl"


def write_json_atomic(path: Path, obj) -> None:
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    with os.fdopen(fd, "w") as f:
        json.dump(obj, f, indent=2, sort_keys=True)
        f.write("\n")
    os.replace(tmp, path)


class MetricsLog:
    """One JSON line per iteration, plus the same scalars as TensorBoard events."""

    def __init__(self, run_dir: Path):
        self.path = run_dir / METRICS_FILE
        self._tb = None
        try:
            from torch.utils.tensorboard import SummaryWriter

            self._tb = SummaryWriter(str(run_dir / "tb"))
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
