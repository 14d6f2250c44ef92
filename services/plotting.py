"""Learning curves: samples vs normalised return, one line per run (e.g. ASI vs RSI)."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

from services.run_dir import CONFIG_FILE, read_metrics


def _label(run_dir: Path) -> str:
    import json

    try:
        config = json.loads((run_dir / CONFIG_FILE).read_text())
        return f"{run_dir.name} ({config.get('init', '?')}, {config.get('motion', '?')})"
    except (OSError, ValueError):
        return run_dir.name


def plot_learning_curves(run_dirs: list[Path], out: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.2), dpi=120)
    for run_dir in run_dirs:
        rows = [r for r in read_metrics(Path(run_dir)) if r.get("normalized_return") is not None]
        if rows:
            ax.plot([r["samples"] for r in rows], [r["normalized_return"] for r in rows], label=_label(Path(run_dir)))
    ax.set_xlabel("samples")
    ax.set_ylabel("normalised return")
    ax.set_ylim(0, 1)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    ax.set_title("Learning curves")
    fig.tight_layout()
    out = Path(out)
    fd, tmp = tempfile.mkstemp(prefix=f".{out.stem}.", suffix=".png", dir=out.parent)
    os.close(fd)
    fig.savefig(tmp)
    plt.close(fig)
    os.replace(tmp, out)
    return out
