"""SFV's Table 2 in spirit: initial-state strategies side by side, from a learning suite's results.

SFV's Table 2 compares FSI (every episode from the clip's first frame), RSI (a uniformly drawn
reference frame) and ASI (starts drawn from a learned Gaussian mixture over phase and state) on
the same clip and budget, and reports ASI > RSI > FSI. This reads what `sfv bench --suite
learning --inits fsi,rsi,asi --seeds 0,1,2` wrote into OUT_DIR/learning.json and the runs'
metrics, and per skill and init gives:
- each seed's final `sfv eval` normalised return and falls (the suite's strict 32 episodes of the
  best checkpoint), their mean and sample standard deviation;
- the in-training evaluation's normalised return at each `--marks` sample count (the last
  evaluation at or before the mark), mean over seeds: how fast, not only how far;
- for ASI, how far its Gaussians moved: the last `asi/mean_shift_sigma` (mean distance of the
  component means from where they started, in units of their starting std) and `asi/std_ratio`
  from the run's metrics, mean over seeds. Where they barely moved, ASI is a perturbed reference
  start at its component phases and the table compares start sets, not a learned distribution;
- the order the data shows: inits sorted by mean final NR, each gap with its standard error
  (sqrt(s1^2/n1 + s2^2/n2)); a gap under two standard errors is reported as not separated.
Runs not complete are listed with their status and left out of the means.

    python bench/scripts/init_comparison.py bench/results/table2_cartwheel [--skill cartwheel] \
        [--marks 1M,2M,3M] [--out bench/results/table2_cartwheel/init_comparison.json]
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from learner.errors import SfvError  # noqa: E402
from services.bench.learning_suite import RESULTS_FILE  # noqa: E402
from services.training.flags import whole_number  # noqa: E402
from services.training.run_dir import read_metrics, write_json_atomic  # noqa: E402

ASI_KEYS = ("asi/mean_shift_sigma", "asi/std_ratio")
SEPARATED_SE = 2.0  # a gap of at least this many standard errors counts as an order the data shows


def mean_std(values: list[float]) -> tuple[float | None, float | None]:
    """Mean and sample standard deviation (None for fewer than two values)."""
    if not values:
        return None, None
    mean = sum(values) / len(values)
    if len(values) < 2:
        return mean, None
    return mean, math.sqrt(sum((v - mean) ** 2 for v in values) / (len(values) - 1))


def eval_at(entry: dict, mark: int) -> float | None:
    """The run's in-training eval NR at the last evaluation at or before `mark` samples."""
    ev = (entry.get("curve") or {}).get("eval") or {}
    best = None
    for samples, value in zip(ev.get("samples") or [], ev.get("eval/normalized_return") or []):
        if samples is not None and samples <= mark and value is not None:
            best = value
    return best


def asi_movement(run_dir: Path) -> dict:
    """The last logged value of each ASI_KEYS key in the run's metrics (empty where none)."""
    last: dict = {}
    for row in read_metrics(run_dir):
        for key in ASI_KEYS:
            if row.get(key) is not None:
                last[key] = float(row[key])
    return last


def seed_row(entry: dict, out_dir: Path, marks: list[int]) -> dict:
    ev = entry.get("eval") or {}
    episodes, rate = ev.get("episodes"), ev.get("fall_rate")
    row = {"seed": entry.get("seed"), "status": entry.get("status"), "samples": entry.get("samples"),
           "minutes": round(entry["wall_s"] / 60.0, 1) if entry.get("wall_s") else None,
           "normalized_return": ev.get("normalized_return"),
           "falls": round(rate * episodes) if episodes and rate is not None else None, "episodes": episodes,
           "eval_at": {str(m): eval_at(entry, m) for m in marks}}
    if entry.get("init") == "asi" and entry.get("run_dir"):
        row.update({key.split("/", 1)[1]: value for key, value in asi_movement(out_dir / entry["run_dir"]).items()})
    return row


def init_summary(rows: list[dict], marks: list[int]) -> dict:
    done = [r for r in rows if r["status"] == "complete" and r["normalized_return"] is not None]
    nr_mean, nr_std = mean_std([r["normalized_return"] for r in done])
    falls = [r["falls"] / r["episodes"] for r in done if r["falls"] is not None and r["episodes"]]
    summary = {"seeds_complete": len(done), "normalized_return_mean": nr_mean, "normalized_return_std": nr_std,
               "fall_rate_mean": mean_std(falls)[0],
               "eval_at_mean": {str(m): mean_std([r["eval_at"][str(m)] for r in done if r["eval_at"][str(m)] is not None])[0]
                                for m in marks}}
    for key in ("mean_shift_sigma", "std_ratio"):
        values = [r[key] for r in done if key in r]
        if values:
            summary[key] = mean_std(values)[0]
    return summary


def order(inits: dict) -> dict:
    """Inits by mean final NR, best first, and each consecutive gap with its standard error."""
    ranked = sorted((name for name, s in inits.items() if s["normalized_return_mean"] is not None),
                    key=lambda name: -inits[name]["normalized_return_mean"])
    gaps = []
    for hi, lo in zip(ranked, ranked[1:]):
        a, b = inits[hi], inits[lo]
        gap = a["normalized_return_mean"] - b["normalized_return_mean"]
        if a["normalized_return_std"] is None or b["normalized_return_std"] is None:
            se = None
        else:
            se = math.sqrt(a["normalized_return_std"] ** 2 / a["seeds_complete"] + b["normalized_return_std"] ** 2 / b["seeds_complete"])
        separated = se is not None and gap >= SEPARATED_SE * se and gap > 0
        gaps.append({"higher": hi, "lower": lo, "gap": gap, "standard_error": se, "separated": separated})
    return {"ranked": ranked, "gaps": gaps, "line": order_line(ranked, gaps)}


def order_line(ranked: list[str], gaps: list[dict]) -> str:
    """'RSI > ASI ~ FSI': '>' where the gap is at least SEPARATED_SE standard errors, '~' where not."""
    if not ranked:
        return "no complete runs"
    text = ranked[0].upper()
    for gap in gaps:
        text += (" > " if gap["separated"] else " ~ ") + gap["lower"].upper()
    return text


def compare(out_dir: Path, skill: str | None, marks: list[int]) -> dict:
    path = out_dir / RESULTS_FILE
    if not path.is_file():
        raise SfvError(f"{path}: no learning suite results here (run `sfv bench --suite learning --out-dir {out_dir}` first)")
    try:
        doc = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise SfvError(f"{path}: not JSON ({exc.msg} at line {exc.lineno})") from None
    runs = list((doc.get("runs") or {}).values())
    skills = sorted({e.get("skill") for e in runs if e.get("skill")})
    if skill is not None:
        if skill not in skills:
            raise SfvError(f"--skill {skill!r}: {path} has runs of {', '.join(skills) or 'no skill'}")
        skills = [skill]
    out = {"results": str(path), "marks": marks, "skills": {}}
    for name in skills:
        entries = sorted((e for e in runs if e.get("skill") == name), key=lambda e: (str(e.get("init")), e.get("seed") or 0))
        per_init: dict = {}
        for entry in entries:
            per_init.setdefault(entry.get("init"), []).append(seed_row(entry, out_dir, marks))
        inits = {init: {**init_summary(rows, marks), "seeds": rows} for init, rows in per_init.items()}
        budget = max((e.get("config") or {}).get("samples") or 0 for e in entries)
        out["skills"][name] = {"budget": budget, "inits": inits, "order": order(inits)}
    return out


def _fmt(value, spec: str = ".3f") -> str:
    return "-" if value is None else format(value, spec)


def markdown(result: dict) -> str:
    marks = result["marks"]
    lines = []
    for name, skill in result["skills"].items():
        lines += [f"{name}, {skill['budget']:,} samples per run: {skill['order']['line']}", "",
                  "| init | seeds | final NR per seed | mean | std | falls per seed | " + " | ".join(f"eval at {m:,}" for m in marks)
                  + " | ASI moved (sigma) | ASI std ratio |",
                  "|---|---:|---|---:|---:|---|" + "---:|" * len(marks) + "---:|---:|"]
        for init in skill["order"]["ranked"] + [i for i in skill["inits"] if i not in skill["order"]["ranked"]]:
            s = skill["inits"][init]
            per_seed = ", ".join(f"{_fmt(r['normalized_return'])}" + ("" if r["status"] == "complete" else f" ({r['status']})")
                                 for r in s["seeds"])
            falls = ", ".join("-" if r["falls"] is None else f"{r['falls']}/{r['episodes']}" for r in s["seeds"])
            lines.append(f"| {init} | {s['seeds_complete']} | {per_seed} | {_fmt(s['normalized_return_mean'])} | "
                         f"{_fmt(s['normalized_return_std'])} | {falls} | "
                         + " | ".join(_fmt(s["eval_at_mean"][str(m)]) for m in marks)
                         + f" | {_fmt(s.get('mean_shift_sigma'), '.2f')} | {_fmt(s.get('std_ratio'), '.2f')} |")
        for gap in skill["order"]["gaps"]:
            lines.append(f"\n{gap['higher']} - {gap['lower']}: {gap['gap']:+.3f} (standard error {_fmt(gap['standard_error'])})"
                         + ("" if gap["separated"] else ", not separated"))
        lines.append("")
    return "\n".join(lines)


def parse_marks(text: str) -> list[int]:
    try:
        marks = [whole_number(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise SfvError(f"--marks {text!r}: give sample counts such as 1M,2M,3M") from None
    if not marks or min(marks) <= 0:
        raise SfvError(f"--marks {text!r}: give positive sample counts such as 1M,2M,3M")
    return marks


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("out_dir", help="a learning suite's --out-dir (its learning.json and runs/)")
    p.add_argument("--skill", default=None, help="one skill (default: every skill in learning.json)")
    p.add_argument("--marks", default="1M,2M,3M", help="sample counts at which to read the in-training evaluation")
    p.add_argument("--out", default=None, help="JSON file for the comparison (written atomically)")
    args = p.parse_args(argv)
    try:
        result = compare(Path(args.out_dir), args.skill, parse_marks(args.marks))
    except SfvError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(markdown(result))
    if args.out:
        write_json_atomic(Path(args.out), result)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
