"""Training runs side by side: what differs in their configs, and how each learned, per sample.

    python bench/scripts/compare_runs.py RUN [RUN ...] --marks 250k,500k,1M --out bench/results/NAME.json [--png NAME.png]

For one-change-at-a-time comparisons (a lever on or off, same clip, same budget). Per run: the
settings that differ from the first run's (dotted config paths), the training curve at each mark
(episode length in control steps, mean reward per step and normalised return, each averaged over
the iterations in the 50 k samples before the mark), every periodic strict evaluation
(`eval/...` rows) and what ended the episodes (`falls/...`, mean over the last ten iterations).
The PNG draws training episode length and evaluated normalised return against samples.

Run directories do not outlive a session here, their summaries do: `--earlier FILE.json[:NAME]`
adds the runs of an earlier comparison's JSON (those whose run directory ends in NAME, or all)
as they were recorded, so a new run is drawn and listed beside the baseline it is measured against.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from learner.errors import SfvError  # noqa: E402
from services.training.run_dir import CONFIG_FILE, METRICS_FILE, read_metrics, read_run_config, write_json_atomic  # noqa: E402

WINDOW = 50_000  # samples before a mark whose iterations are averaged
EVAL_KEYS = ("eval/normalized_return", "eval/fall_rate", "eval/episode_seconds", "eval/joint_rotation_error_rad")


def parse_samples(text: str) -> int:
    """'250k', '1M', '1.5M' or a plain number -> samples."""
    text = text.strip()
    scale = {"k": 1_000, "K": 1_000, "m": 1_000_000, "M": 1_000_000}.get(text[-1:], 1)
    try:
        return int(float(text[:-1] if scale > 1 else text) * scale)
    except ValueError:
        raise SfvError(f"--marks: {text!r} is not a sample count (e.g. 250k, 1M)") from None


def flatten(d: dict, prefix: str = "") -> dict:
    out = {}
    for key, value in d.items():
        path = f"{prefix}{key}"
        out.update(flatten(value, path + ".") if isinstance(value, dict) else {path: value})
    return out


def config_differences(configs: list[dict]) -> list[dict]:
    """Per run, the settings whose value differs from the first run's (paths, out and job id excluded)."""
    ignore = {"out", "job_id", "samples"}
    first = flatten(configs[0])
    diffs = []
    for config in configs:
        flat = flatten(config)
        diffs.append({k: v for k, v in flat.items() if k not in ignore and first.get(k) != v})
    return diffs


def summarise(run_dir: Path, marks: list[int]) -> dict:
    rows = read_metrics(run_dir)
    train = [r for r in rows if "episode_length" in r and r.get("episode_length") is not None]
    at = {}
    for mark in marks:
        window = [r for r in train if mark - WINDOW < r["samples"] <= mark]
        if window:
            mean = lambda key: round(sum(r[key] or 0.0 for r in window) / len(window), 4)  # noqa: E731
            at[str(mark)] = {"episode_length": mean("episode_length"), "reward_mean": mean("reward_mean"),
                             "normalized_return": mean("normalized_return")}
    evals = [{"samples": r["samples"], **{k: round(r[k], 4) for k in EVAL_KEYS if k in r}} for r in rows if "eval/normalized_return" in r]
    last = train[-10:]
    falls = sorted({k for r in last for k in r if k.startswith("falls/")})
    return {"run": str(run_dir), "samples": train[-1]["samples"] if train else 0, "at": at, "eval": evals,
            "falls": {k: round(sum(r.get(k, 0.0) for r in last) / len(last), 3) for k in falls},
            "curve": {"samples": [r["samples"] for r in train], "episode_length": [r["episode_length"] for r in train]}}


def earlier_runs(spec: str) -> list[dict]:
    """The runs of an earlier comparison JSON (`FILE.json` or `FILE.json:NAME`), marked as such."""
    path, _, name = spec.partition(".json:")
    path = path if spec.endswith(".json") and not name else path + ".json"
    try:
        runs = json.loads(Path(path).read_text())["runs"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise SfvError(f"--earlier {spec}: not a comparison JSON with runs ({type(exc).__name__})") from None
    chosen = [dict(r, earlier=path) for r in runs if not name or Path(r.get("run", "")).name == name]
    if not chosen:
        raise SfvError(f"--earlier {spec}: no run named {name!r} in {path}")
    return chosen


def plot(summaries: list[dict], out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from services.training.curves import smooth

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for s in summaries:
        name = Path(s["run"]).name + (" (earlier)" if "earlier" in s else "")
        if "curve" in s:
            top.plot(s["curve"]["samples"], smooth(s["curve"]["episode_length"], 0.8), label=name)
        else:  # an earlier run's curve survives only at its marks
            marks = sorted(s["at"], key=int)
            top.plot([int(m) for m in marks], [s["at"][m]["episode_length"] for m in marks], marker=".", label=name)
        if s["eval"]:
            bottom.plot([e["samples"] for e in s["eval"]], [e["eval/normalized_return"] for e in s["eval"]], marker="o", label=name)
    top.set_ylabel("training episode length (steps)")
    bottom.set_ylabel("eval normalised return")
    bottom.set_xlabel("samples")
    top.legend(fontsize=8)
    fig.tight_layout()
    tmp = out.with_name(f".{out.name}.tmp.png")
    fig.savefig(tmp, dpi=100)
    plt.close(fig)
    tmp.replace(out)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", help="run directories (the first is the baseline of the config differences)")
    parser.add_argument("--marks", default="250k,500k,1M", help="sample counts at which to read the training curves")
    parser.add_argument("--out", required=True, help="JSON file to write")
    parser.add_argument("--png", help="also draw the curves here")
    parser.add_argument("--note", default="", help="a line saying what the comparison is")
    parser.add_argument("--earlier", action="append", default=[], metavar="FILE.json[:NAME]",
                        help="add the runs recorded in an earlier comparison JSON (only the one whose run directory is NAME)")
    args = parser.parse_args(argv)
    try:
        marks = [parse_samples(m) for m in args.marks.split(",") if m.strip()]
        configs = []
        for run in args.runs:
            path = Path(run)
            if not (path / CONFIG_FILE).is_file() or not (path / METRICS_FILE).is_file():
                raise SfvError(f"{run}: not a run directory with metrics (needs {CONFIG_FILE} and {METRICS_FILE})")
            configs.append(read_run_config(path).to_dict())  # older configs upgraded: new fields at the values they ran with
        earlier = [run for spec in args.earlier for run in earlier_runs(spec)]
    except SfvError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    summaries = [summarise(Path(run), marks) for run in args.runs]
    for summary, diff in zip(summaries, config_differences(configs)):
        summary["differs"] = diff
    if args.png:
        plot(earlier + summaries, Path(args.png))
    for s in summaries:
        s.pop("curve")
        line = " ".join(f"{int(m) // 1000}k: {v['episode_length']:.0f} steps" for m, v in s["at"].items())
        last_eval = s["eval"][-1] if s["eval"] else {}
        print(f"{Path(s['run']).name}: {line}; last eval {last_eval.get('eval/normalized_return', '-')} "
              f"at {last_eval.get('samples', '-')}; differs: {s['differs'] or 'baseline'}")
    write_json_atomic(Path(args.out), {"note": args.note, "marks": marks, "runs": earlier + summaries})
    return 0


if __name__ == "__main__":
    sys.exit(main())
