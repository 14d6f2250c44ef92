"""The motor module's distillation levers side by side (issue 47, item 2).

    python -m bench.scripts.npmp_levers --experts DIR --dataset DATA --runs-dir DIR \
        [--levers learned,fixed_0.1,fixed_0.3,fixed_0.1_beta_1] [--updates 6000] [--parallel 2] \
        [--hold-out walk_turn30_mirror] [--one-shot walk run walk_turn60 walk_turn30_mirror]

Every lever distils the same recorded dataset (`sfv distill --dataset DATA`, one process each,
`--parallel` at once, one torch thread) into DIR/<lever>/ and is then measured twice:
- prior samples (`npmp_prior_samples.py`): the frozen decoder on its own AR(1) prior, on white
  latents of the same marginal and on z = 0, 32 ten-second episodes from the task envs' starts:
  falls and seconds. A usable prior falls in under 20 % (the issue's target).
- one-shot imitation (`sfv one-shot`): 8 strict episodes per clip, return relative to the
  clip's expert; >= .8 on trained clips and >= .6 on held-out ones is the target.
Plus the validation KL per step and the decoder's std. Writes bench/results/npmp/levers.json
(rows merged by lever, so levers can be added later) and prints a Markdown table.

A lever is a name and the `sfv distill` flags it sets (LEVERS); `learned` is the defaults of
the module before this script: a learned decoder std with floor .01, beta .1.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))  # run from a checkout without installing

RESULT = ROOT / "bench" / "results" / "npmp" / "levers.json"
LEVERS: dict[str, list[str]] = {
    "learned": [],
    "fixed_0.1": ["--no-learn-action-std", "--init-action-std", "0.1"],
    "fixed_0.3": ["--no-learn-action-std", "--init-action-std", "0.3"],
    "fixed_0.1_beta_1": ["--no-learn-action-std", "--init-action-std", "0.1", "--beta", "1.0"],
    "fixed_0.3_beta_1": ["--no-learn-action-std", "--init-action-std", "0.3", "--beta", "1.0"],
    "learned_beta_0.3": ["--beta", "0.3"],
    "learned_beta_1": ["--beta", "1.0"],
    "learned_beta_3": ["--beta", "3.0"],
    "fixed_0.1_window_30": ["--no-learn-action-std", "--init-action-std", "0.1", "--window", "30", "--batch-windows", "22"],
    "fixed_0.1_white_prior": ["--no-learn-action-std", "--init-action-std", "0.1", "--alpha", "0.0"],
}


def distil(lever: str, args, out: Path) -> subprocess.Popen | None:
    if (out / "decoder.npz").is_file():
        return None
    command = [sys.executable, "-m", "services.cli", "distill", str(args.experts), "--out", str(out), "--dataset", str(args.dataset),
               "--updates", str(args.updates), "--torch-threads", "1", "--quiet", "--hold-out", *args.hold_out, *LEVERS[lever]]
    if any(out.glob("checkpoint_*.pt")):
        command.append("--resume")
    log = open(out.parent / f"{lever}.log", "a")
    return subprocess.Popen(command, cwd=ROOT, stdout=log, stderr=subprocess.STDOUT)


def record_shared_dataset(args) -> None:
    """The dataset every lever shares, recorded once before the levers start (`sfv distill` would
    record it into --dataset too, but two at once would write the same directory)."""
    from services.motor.dataset import MANIFEST
    from services.motor.recorder import RecordConfig, expert_clips, record_dataset

    if (args.dataset / MANIFEST).is_file():
        return
    clips = expert_clips(args.experts, args.clips)
    manifest = record_dataset(args.experts, clips, args.dataset, RecordConfig(steps_per_clip=args.steps_per_clip), progress=False)
    print(f"dataset {args.dataset}: {manifest['steps']} steps of {len(manifest['clips'])} clips", file=sys.stderr)


def validation_figures(module_dir: Path) -> dict:
    rows = [json.loads(line) for line in (module_dir / "metrics.jsonl").read_text().splitlines() if line.strip()]
    last = [r for r in rows if "val/kl" in r][-1]
    return {"val_kl_per_step": last["val/kl"], "val_rmse_rad": last["val/rmse"], "action_std_rad": last["action_std_rad"],
            "updates": last["update"]}


def measure(lever: str, module_dir: Path, args) -> dict:
    from threadpoolctl import threadpool_limits

    from bench.scripts.npmp_prior_samples import run_stream
    from services.motor.one_shot import one_shot_benchmark
    from services.motor.training import load_module
    from services.tasks.pose_prior import PosePrior

    settings = load_module(module_dir).config
    prior = PosePrior.fit()
    with threadpool_limits(1, user_api="blas"):
        streams = {name: run_stream(str(module_dir), name, a, float(settings.prior_std), int(settings.latent_dim), args.episodes, 0, prior)
                   for name, a in (("prior", float(settings.alpha)), ("white", 0.0), ("zero", 0.0))}
    one_shot = one_shot_benchmark(module_dir, Path(args.experts), args.one_shot, args.one_shot_episodes,
                                  module_dir / "one_shot.json", progress=False)
    return {"flags": LEVERS[lever], "module": str(module_dir), **validation_figures(module_dir),
            "prior_samples": {name: {k: row[k] for k in ("fall_rate", "episode_seconds")} for name, row in streams.items()},
            "one_shot": {clip: {"relative_return": row["relative_return"], "held_out": row["held_out"]}
                         for clip, row in one_shot["clips"].items()}}


def markdown(rows: dict) -> str:
    lines = ["| lever | val KL / step | prior falls | white falls | z = 0 falls | one-shot trained (min) | one-shot held out |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for lever, row in rows.items():
        trained = [v["relative_return"] for v in row["one_shot"].values() if not v["held_out"]]
        held = [v["relative_return"] for v in row["one_shot"].values() if v["held_out"]]
        p = row["prior_samples"]
        lines.append(f"| {lever} | {row['val_kl_per_step']:.1f} | {p['prior']['fall_rate']:.2f} | {p['white']['fall_rate']:.2f} | "
                     f"{p['zero']['fall_rate']:.2f} | {sum(trained) / max(1, len(trained)):.2f} ({min(trained, default=float('nan')):.2f}) | "
                     f"{', '.join(f'{v:.2f}' for v in held) or '-'} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    from learner.atomic_io import atomic_write_json

    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--experts", type=Path, required=True, help="experts directory (sfv experts --out)")
    p.add_argument("--dataset", type=Path, required=True, help="recorded dataset, shared by every lever (recorded by the first distil when absent)")
    p.add_argument("--runs-dir", type=Path, required=True, help="one module directory per lever")
    p.add_argument("--levers", default="learned,fixed_0.1,fixed_0.3,fixed_0.1_beta_1")
    p.add_argument("--updates", type=int, default=6000)
    p.add_argument("--parallel", type=int, default=2)
    p.add_argument("--hold-out", nargs="+", default=["walk_turn30_mirror"])
    p.add_argument("--clips", nargs="+", default=None, help="clips recorded into the dataset (default: every expert and its mirror)")
    p.add_argument("--steps-per-clip", type=int, default=12_000)
    p.add_argument("--one-shot", nargs="+", default=["walk", "run", "walk_turn60", "walk_turn30", "walk_turn30_mirror"])
    p.add_argument("--one-shot-episodes", type=int, default=8)
    p.add_argument("--episodes", type=int, default=32, help="prior-sample episodes per stream")
    p.add_argument("--result", type=Path, default=RESULT)
    args = p.parse_args(argv)
    levers = args.levers.split(",")
    unknown = [lever for lever in levers if lever not in LEVERS]
    if unknown:
        raise SystemExit(f"npmp_levers: unknown lever(s) {unknown} (known: {', '.join(LEVERS)})")
    args.runs_dir.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    record_shared_dataset(args)
    pending = list(levers)
    running: dict[str, subprocess.Popen] = {}
    while pending or running:
        while pending and len(running) < args.parallel:
            lever = pending.pop(0)
            process = distil(lever, args, args.runs_dir / lever)
            if process is not None:
                running[lever] = process
        for lever, process in list(running.items()):
            if process.poll() is not None:
                running.pop(lever)
                if process.returncode != 0:
                    raise SystemExit(f"npmp_levers: distilling {lever} failed (exit {process.returncode}); see {args.runs_dir / lever}.log")
        time.sleep(5)
    record = json.loads(args.result.read_text()) if args.result.is_file() else {"rows": {}}
    for lever in levers:
        record["rows"][lever] = measure(lever, args.runs_dir / lever, args)
        record.update(what="distillation levers of the motor module, same dataset (bench/scripts/npmp_levers.py)",
                      dataset=str(args.dataset), hold_out=args.hold_out, updates=args.updates,
                      prior_sample_episodes=args.episodes, one_shot_episodes=args.one_shot_episodes)
        atomic_write_json(args.result, record, sort_keys=False)
    print(markdown({lever: record["rows"][lever] for lever in levers}))
    print(f"wall {time.perf_counter() - started:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
