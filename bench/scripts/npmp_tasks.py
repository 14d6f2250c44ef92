"""Task policies on the motor module against from-scratch joint-space policies (issue 16 item 5).

    python bench/scripts/npmp_tasks.py --module MODULE --runs-dir DIR [--tasks go_to,push_box]
                               [--actions latent,joint,zero] [--seeds 0,1,2] [--samples 750000] [--workers 2]

`zero` is the chance line: no policy, the frozen decoder at z = 0 throughout (what walking
ahead from the start earns), evaluated on the latent runs' env without training.
For each task x action space x seed: trains a run in DIR/<task>_<action>[_s<seed>] with the same sample budget
(resuming a run that stopped early, skipping one that is complete), evaluates it (`sfv task
eval`: 32 deterministic episodes), renders 2 episodes to DIR/<task>_<action>.mp4, and merges
the figures into bench/results/npmp_tasks.json (entries of other task x action pairs already
there are kept, so the pairs can be run one at a time), with the training curves (success rate
against samples, each run) in bench/results/npmp_tasks.png. "samples_to_success_<p>": the
first sample count at which the training success rate, averaged over 5 iterations, reached p.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # run from a checkout without installing

RESULTS = Path(__file__).resolve().parents[2] / "bench" / "results"
THRESHOLDS = (0.25, 0.5)
WINDOW = 5


def samples_to_success(rows: list[dict], threshold: float) -> int | None:
    rates = [(r["samples"], r.get("success_rate")) for r in rows if r.get("success_rate") is not None]
    for k in range(len(rates)):
        window = [rate for _, rate in rates[max(0, k - WINDOW + 1):k + 1]]
        if len(window) == WINDOW and sum(window) / WINDOW >= threshold:
            return int(rates[k][0])
    return None


def field_values(pairs: list[str]) -> dict:
    """`--ppo policy_lr=3e-4 update_epochs=4` (or `--env latent_directions=8`) as config field values (numbers parsed as JSON)."""
    out = {}
    for pair in pairs:
        key, _, value = pair.partition("=")
        try:
            out[key] = json.loads(value)
        except ValueError:
            out[key] = value
    return out


def train(task: str, action: str, args, run_dir: Path) -> float:
    from actors.envs.tasks.config import TaskEnvConfig
    from services.tasks.config import TaskConfig, task_ppo
    from services.tasks.driver import TaskTrainer
    from services.training.run_dir import checkpoint_files, read_metrics

    rows = read_metrics(run_dir)
    if rows and rows[-1]["samples"] >= args.samples:
        return 0.0
    import dataclasses

    ppo = dataclasses.replace(task_ppo(action), **field_values(args.ppo))
    config = TaskConfig(out=str(run_dir), workers=args.workers, envs_per_worker=args.envs_per_worker, samples=args.samples,
                        seed=args.seed, runner=args.runner, torch_threads=args.torch_threads,
                        env=TaskEnvConfig(task=task, action=action, module=args.module if action == "latent" else None,
                                          **(field_values(args.env) if action == "latent" else {})),
                        ppo=ppo)
    started = time.perf_counter()
    with TaskTrainer(config, resume=bool(checkpoint_files(run_dir)), progress=not args.quiet) as trainer:
        trainer.run()
    return time.perf_counter() - started


class ZeroLatents:
    """The chance line's `NumpyPolicy` stand-in: z = 0 for every env, every step."""

    def __init__(self, latent_dim: int):
        self.latent_dim = latent_dim

    def mean(self, obs):
        import numpy as np

        return np.zeros((len(obs), self.latent_dim), np.float32)


def measure_zero(task: str, args) -> dict:
    from actors.envs.tasks.config import TaskEnvConfig
    from actors.envs.tasks.motor_module import load_decoder
    from services.tasks.evaluation import evaluate_task

    env = TaskEnvConfig(task=task, action="latent", module=args.module)
    _, latent_dim = load_decoder(args.module)
    entry = {"run": None, "samples": 0, "module": args.module,
             **evaluate_task(env, None, args.episodes, seed=1000, policy=ZeroLatents(latent_dim))}
    if task == "go_to":
        entry["heatmap"] = heatmap(env, ZeroLatents(latent_dim), f"{task}_zero", args)
    return entry


def heatmap(env_config, policy, name: str, args) -> dict:
    """004 Fig. 6B for this policy: bench/results/npmp/heatmap_<run>.png (+ .json); the mean figures."""
    from services.tasks.heatmap import success_heatmap, write_heatmap

    record = success_heatmap(env_config, policy, seed=1000)
    path = Path(args.results).parent / "npmp" / f"heatmap_{name}.png"
    write_heatmap(record, path, name)
    return {"png": str(path.relative_to(RESULTS.parent.parent)) if path.is_relative_to(RESULTS.parent.parent) else str(path),
            "success_mean": record["success_mean"], "fall_rate_mean": record["fall_rate_mean"]}


def run_name(task: str, action: str, seed: int, label: str = "") -> str:
    return f"{task}_{action}" + (f"_{label}" if label else "") + (f"_s{seed}" if seed else "")


def measure(task: str, action: str, args) -> dict:
    from learner.policy import NumpyPolicy
    from services.tasks.run_dir import load_task_run
    from services.tasks.evaluation import evaluate_task
    from services.tasks.video import render_task
    from services.training.run_dir import read_metrics

    if action == "zero":
        return measure_zero(task, args)
    run_dir = Path(args.runs_dir) / run_name(task, action, args.seed, args.label)
    seconds = train(task, action, args, run_dir)
    config, weights = load_task_run(run_dir)
    rows = read_metrics(run_dir)
    entry = {"run": str(run_dir), "samples": rows[-1]["samples"], "train_seconds_this_call": seconds, "ppo": field_values(args.ppo), "env": field_values(args.env) if action == "latent" else {},
             "module": config.env.module, **evaluate_task(config.env, weights, args.episodes, seed=1000)}
    for p in THRESHOLDS:
        entry[f"samples_to_success_{p}"] = samples_to_success(rows, p)
    entry["final_training_success_rate"] = rows[-1].get("success_rate")
    if task == "go_to":
        entry["heatmap"] = heatmap(config.env, NumpyPolicy(weights, max_batch=256), run_name(task, action, args.seed, args.label), args)
    video = Path(args.runs_dir) / f"{run_name(task, action, args.seed, args.label)}.mp4"
    entry["video"] = render_task(config.env, weights, video, episodes=2, seed=1000, label=f"{task} - {action}")
    return entry


def smoothed(values: list[float], window: int = 10) -> list[float]:
    """Running mean over the last `window` iterations (a 4096-sample batch holds ~13 ten-second episodes)."""
    return [sum(values[max(0, k - window + 1):k + 1]) / len(values[max(0, k - window + 1):k + 1]) for k in range(len(values))]


def plot(results: dict, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from services.training.run_dir import read_metrics

    # the chance line has no curve; a run directory gone (another machine) or a copy at an earlier budget (key@2M) is skipped
    results = {key: entry for key, entry in results.items() if entry.get("run") and Path(entry["run"]).is_dir() and "@" not in key}
    tasks = sorted({key.split("/")[0] for key in results})
    fig, axes = plt.subplots(2, len(tasks), figsize=(6 * len(tasks), 7), squeeze=False)
    for column, task in enumerate(tasks):
        for key, entry in sorted(results.items()):
            if key.split("/")[0] != task:
                continue
            rows = [r for r in read_metrics(Path(entry["run"])) if r.get("success_rate") is not None]
            samples = [r["samples"] for r in rows]
            for row, metric in enumerate(("success_rate", "fall_rate")):
                axes[row][column].plot(samples, smoothed([r[metric] for r in rows]), label="/".join(key.split("/")[1:]))
        axes[0][column].set(title=f"{task}: training episodes reaching a target", xlabel="samples", ylabel="success rate (10-iteration mean)")
        axes[1][column].set(title=f"{task}: training episodes ending in a fall", xlabel="samples", ylabel="fall rate (10-iteration mean)")
        for ax in axes[:, column]:
            ax.legend()
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    plt.close(fig)


def main(argv=None) -> int:
    from learner.atomic_io import atomic_write_json

    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--module", default=None, help="motor module directory (for the latent runs)")
    p.add_argument("--runs-dir", required=True)
    p.add_argument("--tasks", default="go_to")
    p.add_argument("--actions", default="latent,joint")
    p.add_argument("--samples", type=int, default=750_000)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--envs-per-worker", type=int, default=16)
    p.add_argument("--runner", default="ray")
    p.add_argument("--torch-threads", type=int, default=1)
    p.add_argument("--seeds", default="0", help="comma-separated training seeds (a run per seed)")
    p.add_argument("--ppo", nargs="*", default=[], metavar="FIELD=VALUE", help="PPOConfig fields over task_ppo's (a lever)")
    p.add_argument("--env", nargs="*", default=[], metavar="FIELD=VALUE", help="TaskEnvConfig fields of the latent runs (a lever: latent_directions=8)")
    p.add_argument("--label", default="", help="names the lever's runs: <task>_<action>_<label>")
    p.add_argument("--episodes", type=int, default=32)
    p.add_argument("--quiet", action="store_true")
    p.add_argument("--results", default=str(RESULTS / "npmp_tasks.json"))
    args = p.parse_args(argv)
    out = Path(args.results)
    results = json.loads(out.read_text())["runs"] if out.is_file() else {}
    for task in args.tasks.split(","):
        for action in args.actions.split(","):
            for seed in ([0] if action == "zero" else [int(s) for s in args.seeds.split(",")]):
                args.seed = seed
                key = f"{task}/{action}" + (f"_{args.label}" if args.label and action != "zero" else "") + (f"/s{seed}" if action != "zero" else "")
                entry = measure(task, action, args)
                # several invocations may run at once (a lever each): merge into what is on disk now
                record = json.loads(out.read_text()) if out.is_file() else {"bench": "npmp_tasks"}
                record.setdefault("runs", {})[key] = entry  # the file's other keys (earlier tables) are kept
                record["budget_samples"] = args.samples
                results = record["runs"]
                atomic_write_json(out, record)
                print(json.dumps({key: results[key]}), flush=True)
    plot(results, out.with_suffix(".png"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
