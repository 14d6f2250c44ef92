"""The synthetic moving-camera check of issue 15: does physics recover the root path?

A DeepMimic clip seen by a camera that tracks the character loses its root path; what the
video still gives is the joint rotations (here the clip's, plus noise: the 3D prediction's
error), the body-orientation hint and the foot contacts (here from the clip,
`actors/envs/modes/movingcam/clip_cues.py`). Stages:

1. prepare: the clip's root path removed (`services/reconstruction/root_free.make_root_free`),
   hint and contacts from the clean clip, Gaussian noise of `--noise-rad` on every joint
   rotation (a random rotation vector per joint and frame), written as a motion .npz.
2. train (run it under the CPU lock): `sfv train --motion THAT.npz --preset movingcam ...`.
3. report: the trained policy rolled out deterministically from the clip's first frame for
   the horizon (20 s), its simulated root path against the clip's *true* one (the clean clip,
   looped with its cycle offset), both from the same start:
   - path_error_per_m: mean horizontal distance between the simulated and the true root over
     the episode, divided by the true path length travelled; endpoint_error_per_m likewise
     for the last step;
   - heading_error_deg: mean absolute yaw difference of the roots; travel_direction_error_deg:
     angle between the simulated and the true start-to-end displacements;
   - distance_ratio: simulated over true distance travelled;
   plus the strict evaluation by the 002 reward (normalised return, fall rate, survival),
   and contact accuracy (fraction of steps x feet whose simulated contact equals the flag).
   Writes `bench/results/movingcam_synthetic.json`.

    python bench/scripts/movingcam_synthetic.py prepare --out /tmp/mc
    sfv train --motion /tmp/mc/synthetic.npz --preset movingcam --samples 1500000 --torch-threads 1 --out /tmp/mc/run
    python bench/scripts/movingcam_synthetic.py report --out /tmp/mc
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

RESULT = REPO / "bench" / "results" / "movingcam_synthetic.json"


def result_path(clip: str) -> Path:
    """bench/results/movingcam_synthetic.json for the walk (the first check), ..._<clip>.json else."""
    name = clip.rsplit(":", 1)[-1].rsplit("/", 1)[-1].removesuffix(".npz").removesuffix(".txt")
    return RESULT if name == "walk" else RESULT.with_name(f"{RESULT.stem}_{name}.json")
EPISODES = 16  # starts at phases k / 16, as the strict evaluation's


def prepare(clip: str, noise_rad: float, seed: int, out: Path) -> Path:
    from actors.character import quaternion as qn
    from actors.envs.modes.movingcam.clip_cues import clip_cues
    from actors.motion.reference_motion import ReferenceMotion
    from actors.motion.formats.io import load_motion, save_motion
    from services.reconstruction.root_free import make_root_free

    clean = load_motion(clip)
    rng = np.random.default_rng(seed)
    noise = qn.quat_from_axis_angle(rng.normal(0.0, noise_rad / math.sqrt(3.0), clean.joint_rot.shape[:-1] + (3,)))
    noisy = ReferenceMotion(clean.name, clean.frame_times, clean.root_pos, clean.root_rot,
                            qn.quat_normalize(qn.quat_mul(clean.joint_rot, noise)), clean.loop, dict(clean.extras))
    synthetic = make_root_free(noisy)
    synthetic.extras.update(clip_cues(clean))
    synthetic.name = f"{clip.split(':')[-1]}_movingcam_synthetic"
    return save_motion(synthetic, out / "synthetic.npz")


def _yaw(quats: np.ndarray) -> np.ndarray:
    from actors.character import quaternion as qn

    return qn.heading_angle(quats)


def rollout_paths(policy, env, clean, phase: float) -> dict:
    """Deterministic episode from the reference state at `phase` (as the strict evaluation starts
    its episodes) to the horizon or the clip's strict fall rule (`services.training.evaluation`):
    simulated and true root xy and yaw per step, and the contact agreement."""
    from services.training.evaluation import strict_fall_detector

    fell = strict_fall_detector(env)
    obs, _ = env.reset(seed=0, options={"init": "rsi", "phase": phase})
    t0 = float(env.track.times[env.row])
    row = np.zeros((1, env.observation_space.shape[0]), np.float32)
    dt = 1.0 / env.config.control_hz
    sim_xy, sim_yaw, times, agree = [], [], [], []
    start_xy = env.data.qpos[:2].copy()
    for step in range(1, env.max_episode_steps + 1):
        row[0] = obs
        obs, _, terminated, truncated, _ = env.step(policy.mean(row)[0])
        sim_xy.append(env.data.qpos[:2].copy())
        sim_yaw.append(float(_yaw(env.data.qpos[3:7])))
        times.append(step * dt)
        mc = env.movingcam
        agree.append(mc.contacts[0] == (mc.targets.contacts[env.row] > 0.5))
        if terminated or truncated or fell(env.data):
            break
    times = np.asarray(times)
    true = clean.sample(t0 + times)
    true_xy = true.root_pos[:, :2] - clean.sample(np.array([t0])).root_pos[0, :2] + start_xy
    return {"times": times, "sim_xy": np.asarray(sim_xy), "true_xy": true_xy, "sim_yaw": np.asarray(sim_yaw),
            "true_yaw": _yaw(true.root_rot), "start_xy": start_xy, "contact_agreement": np.asarray(agree)}


def path_figures(paths: dict) -> dict:
    sim, true, start = paths["sim_xy"], paths["true_xy"], paths["start_xy"]
    travelled = float(np.linalg.norm(np.diff(np.vstack((start, true)), axis=0), axis=1).sum())
    sim_travelled = float(np.linalg.norm(np.diff(np.vstack((start, sim)), axis=0), axis=1).sum())
    gap = np.linalg.norm(sim - true, axis=1)
    yaw_gap = np.degrees(np.abs(np.angle(np.exp(1j * (paths["sim_yaw"] - paths["true_yaw"])))))
    d_sim, d_true = sim[-1] - start, true[-1] - start
    cos = float(d_sim @ d_true / max(np.linalg.norm(d_sim) * np.linalg.norm(d_true), 1e-12))
    return {
        "survived_s": float(paths["times"][-1]),
        "true_path_m": travelled,
        "sim_path_m": sim_travelled,
        "path_error_per_m": float(gap.mean()) / travelled,
        "endpoint_error_per_m": float(gap[-1]) / travelled,
        "endpoint_error_m": float(gap[-1]),
        "heading_error_deg": float(yaw_gap.mean()),
        "heading_error_end_deg": float(yaw_gap[-1]),
        "travel_direction_error_deg": float(np.degrees(math.acos(max(-1.0, min(1.0, cos))))),
        "distance_ratio": float(np.linalg.norm(d_sim) / max(np.linalg.norm(d_true), 1e-12)),
        "contact_accuracy": float(paths["contact_agreement"].mean()),
    }


def plot_paths(episodes: list[dict], png: Path, clip: str) -> None:
    """Top view: the simulated root paths against the clip's true ones, every episode moved to
    start at the origin."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from learner.atomic_io import atomic_output

    fig, ax = plt.subplots(figsize=(8, 6))
    for k, paths in enumerate(episodes):
        start = paths["start_xy"]
        for key, colour, label in (("true_xy", "tab:blue", f"{clip}: true root path"), ("sim_xy", "tab:orange", "simulated (root-free policy)")):
            xy = np.vstack((start, paths[key])) - start
            ax.plot(xy[:, 0], xy[:, 1], color=colour, lw=1, alpha=0.7, label=label if k == 0 else None)
        ax.plot(*(paths["sim_xy"][-1] - start), "x", color="tab:orange", ms=4)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend()
    ax.set_title(f"movingcam synthetic: {len(episodes)} episodes (x: where each ended)")
    png.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(png) as tmp:
        fig.savefig(tmp, format="png", dpi=100, bbox_inches="tight")
    plt.close(fig)


def report(out: Path, clip: str, noise_rad: float, command: str, result_file: Path | None = None) -> dict:
    from threadpoolctl import threadpool_limits

    from actors.motion.formats.io import load_motion
    from services.training.evaluation import evaluate_policy, make_eval_env, start_phases
    from services.training.policy_source import load_policy_source
    from services.training.run_dir import read_metrics

    result_file = result_path(clip) if result_file is None else Path(result_file)
    run = out / "run"
    source = load_policy_source(run, None, None)
    env = make_eval_env(load_motion(source.motion), source.env_config)
    clean = load_motion(clip)
    phases = start_phases(EPISODES)
    with threadpool_limits(1, user_api="blas"):
        episodes = [rollout_paths(source.policy, env, clean, float(p)) for p in phases]
        strict = evaluate_policy(source.policy, env, EPISODES, seed=0)
    figures = [path_figures(paths) for paths in episodes]
    plot_paths(episodes, result_file.with_suffix(".png"), clip)
    survivors = [f for f in figures if f["survived_s"] >= 0.99 * env.config.horizon_s]
    summary = {key: float(np.mean([f[key] for f in figures])) for key in figures[0]}
    summary_survivors = {key: float(np.mean([f[key] for f in survivors])) for key in figures[0]} if survivors else None
    curve = [{"samples": m["samples"], "normalized_return": m["eval/normalized_return"], "fall_rate": m["eval/fall_rate"],
              "episode_seconds": m["eval/episode_seconds"]} for m in read_metrics(run) if "eval/normalized_return" in m]
    result = {
        "what": f"{clip} through a character-tracking camera: root path removed, hint and contacts from the clip, "
                f"{noise_rad} rad noise on joint rotations; trained root-free in movingcam mode; root path from physics "
                "against the clip's true path (deterministic episode from the first frame)",
        "command": command,
        "episodes": EPISODES,
        "path_mean_over_episodes": summary,
        "path_mean_over_episodes_reaching_the_horizon": summary_survivors,
        "episodes_reaching_the_horizon": len(survivors),
        "path_per_episode": [{"phase": float(p), **{k: round(v, 4) for k, v in f.items()}} for p, f in zip(phases, figures)],
        "eval_002_reward": {k: strict[k] for k in ("normalized_return", "fall_rate", "episode_seconds", "joint_rotation_error_rad", "episodes")},
        "eval_curve": curve,
        "written": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
    }
    result_file.parent.mkdir(parents=True, exist_ok=True)
    from learner.atomic_io import atomic_output

    with atomic_output(result_file) as tmp:
        Path(tmp).write_text(json.dumps(result, indent=1) + "\n")
    return result


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("stage", choices=("prepare", "report"))
    p.add_argument("--out", required=True, type=Path, help="working folder (synthetic.npz, run/)")
    p.add_argument("--clip", default="deepmimic:walk")
    p.add_argument("--noise-rad", type=float, default=0.05, help="std of the joint-rotation noise (rad)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--command", default="", help="the training command, recorded in the result")
    p.add_argument("--result", type=Path, default=None, help="report: the JSON to write (default bench/results/movingcam_synthetic[_<clip>].json)")
    args = p.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.stage == "prepare":
        print(prepare(args.clip, args.noise_rad, args.seed, args.out))
    else:
        print(json.dumps(report(args.out, args.clip, args.noise_rad, args.command, args.result), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
