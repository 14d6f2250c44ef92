"""Adaptive tuple sampling (paper 002 §5.2, eq. 13) against training on every tuple, on a long clip.

    python bench/scripts/adaptive_sampling.py [--motion deepmimic:walk] [--samples 700000] [--eval-every 50000]
        [--runs-dir runs/adaptive_sampling] [--out bench/results/adaptive_sampling.json]

Two ordinary training runs (`services.training.driver.Trainer`, what `sfv train` runs), identical
but for `ppo.tuple_sampling` ("all", then "adaptive"): same seed, same budget of collected
samples. Both write the periodic strict evaluation (`eval/...` rows of metrics.jsonl) and the
per-iteration tuple coverage (`tuple_sampling/...`); this script reads them back and writes
OUT (JSON) and OUT with .png: eval NR against samples and against training time, and the share
of used tuples per frame bin.

The clip: the DeepMimic walk, looped, with the env's 20 s horizon, so the reference track
(`frames`, the reference row of each tuple) is 639 control steps long, and early termination
leaves its late frames rare, the imbalance eq. 13 is for. The longest humanoid3d clip in
pybullet_data (spin) is 4.4 s, 133 steps: a 32-tuple window is a quarter of it. The
episode-length curriculum is off in both arms (`curriculum_start_s=0`): it caps episodes and
so attacks the same imbalance; the paper's Fig. 14 compares adaptive sampling alone.

"samples" are collected environment steps (the simulation cost); adaptive trains on fewer of
them per update, so training time is reported beside them. A rerun resumes an arm that has
checkpoints (`--resume` rules) and skips one that has reached the budget; `--report-only` rewrites
OUT from the runs as they are.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # run from a checkout without installing

ARMS = ("all", "adaptive")
THRESHOLDS = (0.05, 0.06, 0.08, 0.1, 0.2, 0.5)  # an untrained policy scores ~0.04 on the 20 s horizon


def train_config(args, arm: str):
    from services.training.config import TrainConfig

    config = TrainConfig(motion=args.motion, out=str(Path(args.runs_dir) / arm), workers=args.workers,
                         envs_per_worker=args.envs_per_worker, samples=args.samples, seed=args.seed, runner=args.runner,
                         torch_threads=args.torch_threads, eval_every=args.eval_every, eval_episodes=args.eval_episodes,
                         curriculum_start_s=0.0, plot_every=0, checkpoint_every=10)
    config.ppo.tuple_sampling = arm
    return config


def train_arm(args, arm: str) -> None:
    from services.training.driver import Trainer
    from services.training.run_dir import checkpoint_files, read_metrics

    config = train_config(args, arm)
    resume = bool(checkpoint_files(config.out))
    done = resume and max((r.get("samples", 0) for r in read_metrics(Path(config.out))), default=0) >= args.samples
    if done:
        print(f"{arm}: at the budget already", file=sys.stderr)
        return
    if not resume and Path(config.out).exists():  # killed before its first checkpoint: start clean
        for name in ("metrics.jsonl", "config.json"):
            (Path(config.out) / name).unlink(missing_ok=True)
    print(f"{arm}: {'resuming' if resume else 'training'} to {args.samples:,} samples", file=sys.stderr)
    Trainer(config, resume=resume, progress=False).run()


def arm_result(run_dir: Path, thresholds=THRESHOLDS) -> dict:
    """Curves, times, samples to each NR threshold and frame coverage of one arm's metrics.jsonl."""
    from services.bench.learning_report import read_curve, samples_to_threshold
    from services.training.run_dir import read_metrics

    rows = [r for r in read_metrics(run_dir) if "samples" in r and "samples_per_s" in r]
    steps = np.diff([0] + [r["samples"] for r in rows])
    iteration_s = steps / np.array([r["samples_per_s"] for r in rows])
    sampling_s = steps / np.array([r["sampling_samples_per_s"] for r in rows])
    eval_s = np.array([r.get("eval/seconds", 0.0) for r in rows])
    curve = read_curve(run_dir)
    ev = curve["eval"]
    train_s = np.cumsum(iteration_s)
    at = {r["samples"]: float(t) for r, t in zip(rows, train_s)}
    used = np.sum([r["tuple_sampling/used_per_frame_bin"] for r in rows], axis=0)
    collected = np.sum([r["tuple_sampling/collected_per_frame_bin"] for r in rows], axis=0)
    return {
        "samples": int(rows[-1]["samples"]),
        "iterations": len(rows),
        "train_s": float(iteration_s.sum()),  # collect + update + bookkeeping, evaluations excluded
        "sampling_s": float(sampling_s.sum()),
        "sampling_samples_per_s_median": float(np.median(steps / sampling_s)),  # the machine's load during the arm
        "update_s": float((iteration_s - sampling_s).sum()),
        "eval_s": float(eval_s.sum()),
        "eval_curve": {"samples": ev.get("samples", []), "train_s": [at.get(s) for s in ev.get("samples", [])],
                       "normalized_return": ev.get("eval/normalized_return", []), "fall_rate": ev.get("eval/fall_rate", []),
                       "episode_seconds": ev.get("eval/episode_seconds", [])},
        "final_eval_normalized_return": (ev.get("eval/normalized_return") or [None])[-1],
        "best_eval_normalized_return": max((v for v in ev.get("eval/normalized_return", []) if v is not None), default=None),
        "samples_to_nr": {str(t): samples_to_threshold(curve, 0, None, t)[0] for t in thresholds},
        "train_s_to_nr": {str(t): at.get(samples_to_threshold(curve, 0, None, t)[0]) for t in thresholds},
        "tuples_used_fraction": float(used.sum() / max(collected.sum(), 1)),
        "frame_entropy_mean": float(np.mean([r["tuple_sampling/frame_entropy"] for r in rows])),
        "frame_count_min_mean": float(np.mean([r["tuple_sampling/frame_count_min"] for r in rows])),
        "frame_count_max_mean": float(np.mean([r["tuple_sampling/frame_count_max"] for r in rows])),
        "frame_bins": {"used": used.tolist(), "collected": collected.tolist()},
    }


def plot(result: dict, out: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from services.training.curves import save_figure

    fig, (a, b, c) = plt.subplots(1, 3, figsize=(15, 4.2))
    for arm, colour in zip(ARMS, ("tab:orange", "tab:blue")):
        r = result["arms"][arm]
        ev = r["eval_curve"]
        a.plot(ev["samples"], ev["normalized_return"], "o-", color=colour, label=f"{arm} ({r['tuples_used_fraction']:.0%} of tuples used)")
        b.plot(ev["train_s"], ev["normalized_return"], "o-", color=colour, label=arm)
        bins = np.asarray(r["frame_bins"]["used"], dtype=float)
        edges = np.linspace(0, result["frames"], len(bins) + 1)
        c.step(edges[:-1], bins / max(bins.sum(), 1), where="post", color=colour, label=f"{arm}: used")
    collected = np.asarray(result["arms"]["all"]["frame_bins"]["collected"], dtype=float)
    c.step(np.linspace(0, result["frames"], len(collected) + 1)[:-1], collected / collected.sum(), where="post", color="grey", ls=":", label="all: collected")
    a.set(xlabel="collected samples", ylabel="eval normalised return (strict)", title=f"{result['motion']}, {result['horizon_s']:g} s horizon")
    b.set(xlabel="training time, s (evaluations excluded)", ylabel="eval normalised return", title="against time")
    reached = np.flatnonzero(collected)
    c.set(xlabel="frame (reference row)", ylabel="share of tuples", title="frame coverage over the run", yscale="log",
          xlim=(0, (reached[-1] + 2) * result["frames"] / len(collected) if reached.size else result["frames"]))
    for ax in (a, b, c):
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    return save_figure(fig, out)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--motion", default="deepmimic:walk")
    parser.add_argument("--samples", type=int, default=700_000, help="collected samples per arm")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--envs-per-worker", type=int, default=32)
    parser.add_argument("--runner", default="ray", choices=("ray", "in_process", "processes"))
    parser.add_argument("--torch-threads", type=int, default=1)
    parser.add_argument("--eval-every", type=int, default=50_000)
    parser.add_argument("--eval-episodes", type=int, default=8)
    parser.add_argument("--thresholds", type=lambda t: tuple(float(x) for x in t.split(",")), default=THRESHOLDS,
                        help="eval NRs to report the samples (and training time) to, comma separated")
    parser.add_argument("--runs-dir", default="runs/adaptive_sampling")
    parser.add_argument("--out", default="bench/results/adaptive_sampling.json")
    parser.add_argument("--report-only", action="store_true", help="write OUT from the runs as they are, training nothing")
    args = parser.parse_args(argv)
    from actors.envs.imitation_env import ImitationEnv
    from actors.motion.formats.io import load_motion
    from services.training.run_dir import write_json_atomic

    started = time.time()
    for arm in ARMS if not args.report_only else ():
        train_arm(args, arm)
    config = train_config(args, "all")
    frames = ImitationEnv(load_motion(args.motion), config.env).track.rows
    result = {
        "what": "adaptive tuple sampling (002 §5.2 eq. 13, 32 tuples per episode segment) vs every tuple; same seed and "
                "collected-sample budget; strict periodic evaluation; curriculum off",
        "motion": args.motion, "horizon_s": config.env.horizon_s, "frames": frames, "seed": args.seed,
        "init": config.init, "workers": args.workers, "envs_per_worker": args.envs_per_worker, "runner": args.runner,
        "batch_size": config.ppo.batch_size, "eval_every": args.eval_every, "eval_episodes": args.eval_episodes,
        "machine": "2 cores shared with other trainings (runs serialised by a CPU lock, other load not): compare "
                   "times only where the arms' sampling_samples_per_s_median agree",
        "wall_s_this_invocation": time.time() - started,
        "arms": {arm: arm_result(Path(args.runs_dir) / arm, args.thresholds) for arm in ARMS},
    }
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(out, result)
    plot(result, out.with_suffix(".png"))
    print(json.dumps({arm: {k: v for k, v in r.items() if k not in ("eval_curve", "frame_bins")} for arm, r in result["arms"].items()}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
