"""Make the motor module that ships in the repository (`--module pretrained`), from nothing.

    python -m bench.scripts.npmp_pretrained --runs-dir runs/npmp_pretrained [--ship]

Steps, each skipped when its output is there (rerun the command after a kill to continue):
1. the turning walks: `sfv motion bend deepmimic:walk --yaw-rate R --seconds 10` for each R of TURNS
   (degrees per second, left; their mirrors turn right);
2. the experts: `sfv experts walk run --samples 2000000`, then the turns at 1.5 M (one Ray job each,
   two trainings at once);
3. the module: `sfv distill --spec npmp-pretrained`: every clip and its mirror (`sfv experts`'
   mirrored experts), `walk_turn30_mirror` held out for one-shot imitation, beta 0.3 (the lever
   table, bench/results/npmp/levers.json);
4. `--ship`: its config.json, decoder.npz and decoder.onnx copied into learner/pretrained/motor_module
   with PROVENANCE.md (these commands, the experts' samples and NR, the module's figures).
On this 2-core machine steps 2-3 take about 1 h 15 min (2026-12-06).
"""
from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

TURNS = (30, 60)
EXPERT_SAMPLES = {"walk": 2_000_000, "run": 2_000_000, **{f"walk_turn{r}": 1_500_000 for r in TURNS}}
UPDATES = 6000  # the distill spec `npmp-pretrained` holds the clips, the held-out clip, steps per clip and beta
SHIPPED = ("config.json", "decoder.npz", "decoder.onnx")


def sfv(*args: str) -> None:
    command = [sys.executable, "-m", "services.cli", *args]
    print("$ sfv " + " ".join(args), flush=True)
    subprocess.run(command, cwd=ROOT, check=True)


def clip_names() -> list[str]:
    """The recorded clips, originals first (a clip's index seeds its recording noise)."""
    return [*EXPERT_SAMPLES, *(f"{clip}_mirror" for clip in EXPERT_SAMPLES)]


def make(runs: Path) -> Path:
    clips_dir, experts, module = runs / "clips", runs / "experts", runs / "module"
    clips_dir.mkdir(parents=True, exist_ok=True)
    for rate in TURNS:
        path = clips_dir / f"walk_turn{rate}.npz"
        if not path.is_file():
            sfv("motion", "bend", "deepmimic:walk", "--yaw-rate", str(rate), "--seconds", "10", "--name", path.stem, "--out", str(path))
    by_budget: dict[int, list[str]] = {}
    for clip, samples in EXPERT_SAMPLES.items():
        by_budget.setdefault(samples, []).append(clip if not clip.startswith("walk_turn") else str(clips_dir / f"{clip}.npz"))
    for samples, clips in by_budget.items():
        sfv("experts", *clips, "--out", str(experts), "--samples", str(samples), "--parallel", "2", "--quiet")
    if not (module / "decoder.npz").is_file():
        sfv("distill", str(experts), "--out", str(module), "--dataset", str(runs / "dataset"), "--spec", "npmp-pretrained",
            "--updates", str(UPDATES), "--torch-threads", "1", "--quiet", *(["--resume"] if any(module.glob("checkpoint_*.pt")) else []))
    return module


def expert_rows(experts: Path) -> list[str]:
    from services.training.run_dir import read_metrics

    rows = []
    for clip in EXPERT_SAMPLES:
        metrics = read_metrics(experts / clip)
        evals = [r for r in metrics if r.get("eval/normalized_return") is not None]
        nr = f"{evals[-1]['eval/normalized_return']:.3f}" if evals else "-"
        rows.append(f"| {clip} | {metrics[-1]['samples'] / 1e6:.1f} M | {nr} |")
    return rows


def ship(runs: Path, target: Path, figures: dict) -> None:
    from learner.atomic_io import atomic_write_text

    module = runs / "module"
    target.mkdir(parents=True, exist_ok=True)
    for name in SHIPPED:
        shutil.copyfile(module / name, target / name)
    record = json.loads((module / "config.json").read_text())
    lines = ["# The shipped motor module (`--module pretrained`)", "",
             f"Made on {time.strftime('%Y-%m-%d')} by `python -m bench.scripts.npmp_pretrained --runs-dir RUNS --ship`, which runs:", "",
             "```bash",
             *[f"sfv motion bend deepmimic:walk --yaw-rate {r} --seconds 10 --name walk_turn{r} --out RUNS/clips/walk_turn{r}.npz" for r in TURNS],
             "sfv experts walk run --out RUNS/experts --samples 2000000 --parallel 2",
             "sfv experts " + " ".join(f"RUNS/clips/walk_turn{r}.npz" for r in TURNS) + " --out RUNS/experts --samples 1500000 --parallel 2",
             f"sfv distill RUNS/experts --out RUNS/module --spec npmp-pretrained --updates {UPDATES}   "
             "# clips " + " ".join(clip_names()) + ", walk_turn30_mirror held out, 12,000 steps per clip, beta 0.3",
             "```", "",
             "Experts (NR of the last in-training evaluation, 8 strict episodes; `<clip>_mirror` is each expert mirrored, not trained):", "",
             "| expert | samples | NR |", "|---|---:|---:|", *expert_rows(runs / "experts"), "",
             f"Module: trained on {', '.join(record['clips'])}; held out {', '.join(record['held_out'])}.",
             f"Settings: {json.dumps(record['module'], sort_keys=True)}", "",
             "Figures (bench/results/npmp/):", "", "```json", json.dumps(figures, indent=1, sort_keys=True), "```", ""]
    atomic_write_text(target / "PROVENANCE.md", "\n".join(lines))


def main(argv=None) -> int:
    from learner.motor_decoder import PRETRAINED_DIR

    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--runs-dir", type=Path, required=True)
    p.add_argument("--ship", action="store_true", help=f"copy the module into {PRETRAINED_DIR.relative_to(ROOT)}")
    p.add_argument("--figures", type=Path, nargs="*", default=[ROOT / "bench/results/npmp/prior_samples.json",
                                                             ROOT / "bench/results/npmp/one_shot.json"],
                   help="JSON files whose contents go into PROVENANCE.md")
    args = p.parse_args(argv)
    make(args.runs_dir)
    if args.ship:
        figures = {path.name: json.loads(path.read_text()) for path in args.figures if path.is_file()}
        ship(args.runs_dir, PRETRAINED_DIR, figures)
        print(f"shipped {args.runs_dir / 'module'} -> {PRETRAINED_DIR}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
