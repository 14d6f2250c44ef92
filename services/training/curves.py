"""Learning curves: samples vs normalised return, one line per run, coloured by init strategy.

The trainer redraws `learning_curve.png` in its run directory while it trains; `sfv plot`
draws several runs together (the paper's ASI vs RSI comparison). Each iteration's return is
a noisy mean over the episodes that ended in it, so the raw curve is drawn faint and an
exponential moving average over it bold. When the metrics hold periodic evaluations
(`eval/...` rows: deterministic episodes at evenly spaced phases, strict falls), their
normalised return is drawn as square markers joined by a thin line in the run's colour beside
the training return, and their fall rate in a panel underneath.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from learner.atomic_io import atomic_output
from services.training.run_dir import CONFIG_FILE, read_metrics

INIT_COLOURS = {"asi": "tab:blue", "rsi": "tab:orange", "fsi": "tab:green"}
LINE_STYLES = ("-", "--", ":", "-.")


def run_info(run_dir: Path) -> dict:
    """Init strategy and motion from the run's config.json ('?' when unreadable)."""
    try:
        config = json.loads((Path(run_dir) / CONFIG_FILE).read_text())
        return {"init": str(config.get("init", "?")), "motion": str(config.get("motion", "?"))}
    except (OSError, ValueError, AttributeError):
        return {"init": "?", "motion": "?"}


def learning_curve(run_dir: Path) -> tuple[np.ndarray, np.ndarray]:
    """(samples, normalised return) of the iterations that finished at least one episode."""
    rows = [r for r in read_metrics(Path(run_dir)) if r.get("normalized_return") is not None and "samples" in r]
    return (np.array([r["samples"] for r in rows], dtype=np.float64),
            np.array([r["normalized_return"] for r in rows], dtype=np.float64))


def eval_curve(run_dir: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(samples, eval normalised return, eval fall rate) of the iterations that ran an evaluation."""
    rows = [r for r in read_metrics(Path(run_dir)) if r.get("eval/normalized_return") is not None and "samples" in r]
    fall = [r.get("eval/fall_rate") for r in rows]
    return (np.array([r["samples"] for r in rows], dtype=np.float64),
            np.array([r["eval/normalized_return"] for r in rows], dtype=np.float64),
            np.array([np.nan if f is None else f for f in fall], dtype=np.float64))


def smooth(values: np.ndarray, weight: float) -> np.ndarray:
    """Bias-corrected exponential moving average (TensorBoard's smoothing)."""
    out = np.empty_like(values)
    average, norm = 0.0, 0.0
    for index, value in enumerate(values):
        average = weight * average + (1.0 - weight) * value
        norm = weight * norm + (1.0 - weight)
        out[index] = average / norm
    return out


def plot_learning_curves(run_dirs: list[Path], out: Path, smoothing: float = 0.8) -> Path:
    """Draw the runs' curves into `out` (PNG, written atomically); returns `out`."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import EngFormatter

    run_dirs = [Path(r) for r in run_dirs]
    evals = {run_dir: eval_curve(run_dir) for run_dir in run_dirs}
    with_eval = any(len(curve[0]) for curve in evals.values())
    if with_eval:
        fig, (ax, fall_ax) = plt.subplots(2, 1, figsize=(7, 5.6), dpi=120, sharex=True, gridspec_kw={"height_ratios": (3, 1)})
    else:
        fig, ax = plt.subplots(figsize=(7, 4.2), dpi=120)
        fall_ax = None
    per_init: dict[str, int] = {}
    motions = set()
    highest = 0.0
    for run_dir in run_dirs:
        samples, returns = learning_curve(run_dir)
        eval_samples, eval_returns, eval_falls = evals[run_dir]
        info = run_info(run_dir)
        motions.add(info["motion"])
        colour = INIT_COLOURS.get(info["init"], "tab:gray")
        style = LINE_STYLES[per_init.get(info["init"], 0) % len(LINE_STYLES)]
        per_init[info["init"]] = per_init.get(info["init"], 0) + 1
        label = f"{info['init'].upper()}: {run_dir.name}"
        if len(samples) == 0:
            ax.plot([], [], color=colour, linestyle=style, label=f"{label} (no episodes yet)")
        elif len(samples) > 1 and smoothing > 0:
            ax.plot(samples, returns, color=colour, alpha=0.25, linewidth=1)
            ax.plot(samples, smooth(returns, smoothing), color=colour, linestyle=style, linewidth=2, label=label)
        else:
            ax.plot(samples, returns, color=colour, linestyle=style, linewidth=2, marker="o", label=label)
        if len(samples):
            highest = max(highest, float(max(returns)))
        if len(eval_samples):  # deterministic, strict evaluations: squares on a thin line, same colour
            highest = max(highest, float(np.nanmax(eval_returns)))
            ax.plot(eval_samples, eval_returns, color=colour, linestyle=style, linewidth=1, marker="s", markersize=4,
                    markeredgecolor="black", markeredgewidth=0.5, label=f"{label} eval (strict)")
            fall_ax.plot(eval_samples, eval_falls, color=colour, linestyle=style, linewidth=1, marker="s", markersize=4,
                         markeredgecolor="black", markeredgewidth=0.5)
    bottom = fall_ax if fall_ax is not None else ax
    bottom.set_xlabel("samples")
    bottom.xaxis.set_major_formatter(EngFormatter())
    ax.set_ylabel("normalised return")
    if fall_ax is not None:
        fall_ax.set_ylabel("eval fall rate")
        fall_ax.set_ylim(-0.05, 1.05)
        fall_ax.grid(alpha=0.3)
    # The scale is 0..1; early in training a full-height axis hides the curves, so zoom in.
    ax.set_ylim(0, 1.0 if highest > 0.5 else max(0.02, 1.25 * highest))
    ax.grid(alpha=0.3)
    if run_dirs:
        ax.legend(loc="upper left", fontsize=8, title="init: run", title_fontsize=8)
    ax.set_title(f"Learning curves: {', '.join(sorted(motions)) or 'no runs'}")
    return save_figure(fig, out)


def save_figure(fig, out) -> Path:
    """Lay out, write `out` atomically (temp name, then rename) and close the figure."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    out = Path(out)
    try:
        with atomic_output(out, suffix=".png") as tmp:
            fig.savefig(tmp)
    finally:
        plt.close(fig)
    return out
