"""What a learning suite's record says: each run's curves, when it crossed the threshold, result lines, the table and the plot.

`services/bench/learning_suite.py` trains and records; this reads a run's metrics.jsonl into the
record's "curve" (training NR per iteration and every periodic `eval/...` row, with the training
seconds up to each) and turns learning.json's document into what people look at: one result
line per run, the skill x init markdown table (mean over seeds of the final eval, samples and
minutes to the threshold) and learning.png (one panel per skill, one line per init and seed).
"""
from __future__ import annotations

from pathlib import Path

from services.training.config import INIT_MODES

INITS = INIT_MODES  # every initial-state strategy, in the order the table and plot list them
THRESHOLD = 0.8  # normalised return counted as learned
SMOOTHING = 0.8  # EMA weight of training curves, as services.training.curves draws them


def read_curve(run_dir: Path) -> dict:
    """Training and evaluation curves from the run's metrics.jsonl (an eval row may be its own line or part of an iteration's)."""
    from services.bench.run_history import active_seconds
    from services.training.run_dir import read_metrics

    train = {"samples": [], "normalized_return": [], "fall_rate": [], "episode_length": [], "wall_s": []}
    evals: list[dict] = []
    rows = [row for row in read_metrics(run_dir) if "samples" in row]
    for row, seconds in zip(rows, active_seconds(rows)):
        row = {**row, "wall_s": seconds}
        if row.get("normalized_return") is not None:
            for key in train:
                train[key].append(row.get(key))
        picked = {k: v for k, v in row.items() if k.startswith("eval/")}
        if picked.get("eval/normalized_return") is not None:
            evals.append({"samples": row["samples"], "wall_s": seconds, **picked})
    keys = ["samples", "wall_s"] + sorted({k for e in evals for k in e if k not in ("samples", "wall_s")})
    return {"train": train, "eval": {k: [e.get(k) for e in evals] for k in keys}}


def samples_to_threshold(curve: dict, final_samples: int, final_nr, threshold: float) -> tuple[int | None, str]:
    """First sample count at which NR >= threshold: eval rows where there are any, else the smoothed
    training curve; the final evaluation counts as a last point either way."""
    import numpy as np

    from services.training.curves import smooth

    if curve["eval"].get("samples"):
        points = list(zip(curve["eval"]["samples"], curve["eval"]["eval/normalized_return"]))
        source = "eval"
    else:
        train = curve["train"]
        values = smooth(np.asarray(train["normalized_return"], dtype=np.float64), SMOOTHING) if train["samples"] else []
        points = list(zip(train["samples"], (float(v) for v in values)))
        source = "train_smoothed"
    if final_nr is not None:
        points.append((final_samples, final_nr))
    for samples, value in points:
        if value is not None and value >= threshold:
            return int(samples), source
    return None, source



def _fmt(value, spec: str = ".3f") -> str:
    return "-" if value is None else format(value, spec)


def result_line(entry: dict) -> str:
    ev = entry.get("eval", {})
    return (f"{entry['skill']} {entry['init']} seed {entry['seed']}: {entry['samples']:,} samples in "
            f"{entry['wall_s'] / 60:.1f} min, eval NR {_fmt(ev.get('normalized_return'))}, "
            f"fall rate {_fmt(ev.get('fall_rate'), '.2f')}")


def _ordered_skills(doc: dict, skills=()) -> list[str]:
    seen = [s for s in skills if any(e.get("skill") == s for e in doc["runs"].values())]
    for entry in doc["runs"].values():
        if entry.get("skill") not in seen:
            seen.append(entry.get("skill"))
    return seen


def _complete(doc: dict, skill: str) -> list[dict]:
    runs = [e for e in doc["runs"].values() if e.get("skill") == skill and e.get("status") == "complete"]
    return sorted(runs, key=lambda e: (INITS.index(e["init"]) if e["init"] in INITS else 9, e["seed"]))


def markdown_table(doc: dict, skills=()) -> str:
    """skill x init: mean over seeds of the final eval NR and fall rate, and the samples to reach the threshold."""
    threshold = doc.get("threshold", THRESHOLD)
    lines = [f"| skill | init | seeds | samples | minutes | eval NR | falls | samples to NR {threshold:g} |",
             "|---|---|---:|---:|---:|---:|---:|---:|"]
    for skill in _ordered_skills(doc, skills):
        runs = _complete(doc, skill)
        for init in dict.fromkeys(e["init"] for e in runs):
            group = [e for e in runs if e["init"] == init]
            nr = _mean([e["eval"].get("normalized_return") for e in group])
            fall = _mean([e["eval"].get("fall_rate") for e in group])
            reached = sorted((e["samples_to_threshold"], minutes_to_threshold(e)) for e in group if e.get("samples_to_threshold") is not None)
            if not reached:
                to = "not reached"
            else:
                median, minutes = reached[len(reached) // 2]
                to = (f"{median:,}" + ("" if minutes is None else f" ({minutes:.{0 if minutes >= 10 else 1}f} min)")
                      + ("" if len(reached) == len(group) else f" ({len(reached)}/{len(group)} seeds)"))
            samples = max(e["samples"] for e in group)
            minutes = _mean([e.get("wall_s") / 60.0 if e.get("wall_s") else None for e in group])
            lines.append(f"| {skill} | {init} | {len(group)} | {samples:,} | {_fmt(minutes, '.1f')} | {_fmt(nr)} | "
                         f"{_falls(group, fall)} | {to} |")
    return "\n".join(lines)


def _falls(group: list[dict], mean_rate) -> str:
    """One run: its falls out of its episodes (3 / 32); several: the mean fall rate."""
    if len(group) == 1:
        ev = group[0]["eval"]
        episodes, rate = ev.get("episodes"), ev.get("fall_rate")
        if episodes and rate is not None:
            return f"{round(rate * episodes)} / {episodes}"
    return _fmt(mean_rate, ".2f")


def minutes_to_threshold(entry: dict) -> float | None:
    """Training minutes to the threshold: the time stamp of the evaluation that crossed it where the
    curve has one, else the run's own average rate (samples / wall_s)."""
    rate, reached = entry.get("samples_per_s"), entry.get("samples_to_threshold")
    if reached is None:
        return None
    ev = (entry.get("curve") or {}).get("eval") or {}
    for samples, seconds in zip(ev.get("samples") or [], ev.get("wall_s") or []):
        if samples == reached and seconds is not None:
            return seconds / 60.0
    return None if not rate else reached / rate / 60.0


def _mean(values):
    values = [v for v in values if v is not None]
    return sum(values) / len(values) if values else None


def plot(doc: dict, out: Path, skills=()) -> Path:
    """One panel per skill: eval NR against samples (the smoothed training NR where a run has no eval rows), one line per init and seed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.ticker import EngFormatter

    from services.training.curves import INIT_COLOURS, LINE_STYLES, save_figure, smooth

    names = _ordered_skills(doc, skills) or ["no runs"]
    ncols = min(2, len(names))
    nrows = -(-len(names) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(6.2 * ncols, 3.9 * nrows), dpi=120, squeeze=False)
    threshold = doc.get("threshold", THRESHOLD)
    for ax, skill in zip(axes.flat, names):
        runs = _complete(doc, skill)
        seeds = sorted({e["seed"] for e in runs})
        highest = 0.0
        for entry in runs:
            colour = INIT_COLOURS.get(entry["init"], "tab:gray")
            style = LINE_STYLES[seeds.index(entry["seed"]) % len(LINE_STYLES)]
            label = f"{entry['init'].upper()} s{entry['seed']}"
            ev = entry["curve"]["eval"]
            if ev.get("samples"):
                xs = np.asarray(ev["samples"], dtype=np.float64)
                ys = np.asarray([np.nan if v is None else v for v in ev["eval/normalized_return"]], dtype=np.float64)
                ax.plot(xs, ys, color=colour, linestyle=style, linewidth=2, marker="o", markersize=3, label=label)
            else:
                tr = entry["curve"]["train"]
                xs = np.asarray(tr["samples"], dtype=np.float64)
                ys = np.asarray(tr["normalized_return"], dtype=np.float64)
                label += " (training NR)"
                if len(xs) > 1:
                    ax.plot(xs, ys, color=colour, alpha=0.25, linewidth=1)
                    ax.plot(xs, smooth(ys, SMOOTHING), color=colour, linestyle=style, linewidth=2, label=label)
                elif len(xs):
                    ax.plot(xs, ys, color=colour, linestyle=style, linewidth=2, marker="o", label=label)
                else:
                    ax.plot([], [], color=colour, linestyle=style, label=f"{label}: no episodes")
            final = entry["eval"].get("normalized_return")
            if final is not None:  # the evaluation after training, as a hollow marker at the end
                ax.plot([entry["samples"]], [final], color=colour, marker="D", markerfacecolor="none", linestyle="none")
            finite = ys[np.isfinite(ys)]
            highest = max(highest, float(finite.max()) if len(finite) else 0.0, final or 0.0)
        top = 1.0 if highest > 0.5 else max(0.02, 1.25 * highest)
        if threshold <= top:
            ax.axhline(threshold, color="gray", linestyle=":", linewidth=1)
        ax.set_ylim(0, top)
        ax.set_title(skill)
        ax.set_xlabel("samples")
        ax.xaxis.set_major_formatter(EngFormatter())
        ax.set_ylabel("normalised return")
        ax.grid(alpha=0.3)
        if runs:
            ax.legend(loc="upper left", fontsize=8, framealpha=0.8, title="init seed (eval; diamond: final)", title_fontsize=8)  # curves rise to the right: upper left is clear
    for ax in list(axes.flat)[len(names):]:
        ax.axis("off")
    fig.suptitle("Learning: normalised return against samples")
    return save_figure(fig, out)


def _plot_safely(doc: dict, out: Path, skills, log) -> None:
    try:
        plot(doc, out, skills)
    except Exception as exc:  # the figures are in learning.json; a plot must not lose them
        log(f"learning.png not drawn: {exc}")


