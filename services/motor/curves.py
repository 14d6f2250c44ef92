"""The distillation's loss curve: ELBO loss (train, validation), KL and target RMSE against steps seen."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from learner.atomic_io import atomic_output
from services.training.run_dir import read_metrics

CURVE_FILE = "loss_curve.png"


def plot_loss_curve(module_dir: Path) -> Path | None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in read_metrics(Path(module_dir)) if "loss" in r]
    if not rows:
        return None
    samples = np.array([r["samples"] for r in rows], dtype=float)
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6), dpi=110)
    for ax, key, title in zip(axes, ("loss", "kl", "rmse"), ("loss: -log pi + beta KL (per step)", "KL(q || p) (nats per step)", "RMSE of the targets (rad)")):
        ax.plot(samples, [r[key] for r in rows], label="train")
        validation = [(s, r[f"val/{key}"]) for s, r in zip(samples, rows) if f"val/{key}" in r]
        if validation:
            ax.plot(*zip(*validation), label="validation (encoder mean)")
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("steps seen")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    path = Path(module_dir) / CURVE_FILE
    with atomic_output(path, suffix=".png") as tmp:
        fig.savefig(tmp)
    plt.close(fig)
    return path
