"""The expert table: how well each clip's expert tracks (004 §3.2, Fig. 3B).

Per expert (a trained `DIR/<clip>/` and, by symmetry, `<clip>_mirror`):
- the strict evaluation of `services/training/evaluation.py` (`episodes` deterministic
  episodes from evenly spaced phases, strict falls): normalised return (NR), fall rate,
  survival (mean seconds before a fall or the episode's end), joint-rotation error (rad) and
  end-effector error (m);
- Fig. 3B's curve: tracking error against time since initialisation. Rollouts start from the
  reference state at `starts` evenly spaced points of the clip and run to the clip's end (as
  in 004) or `curve_seconds`, whichever comes first; looped clips run `curve_seconds`. The
  rollouts are not cut at a fall (a fallen character's error is what the curve is to show);
  the fraction fallen by each time is recorded beside it. At each time the curve is the mean
  over the starts still running.
Each row is measured on its run's body (config.json's `env.character`: the humanoid3d's 12
joints and 4 end effectors, or the G1's 29 hinges and its ankle-roll and wrist-yaw links),
through the env's own reward layout; a mirrored row acts on its original's body (the G1's
mirrored experts by its hinge mirror signs, `actors/character/mirror.py`).
Deviation: 004's tracking error is its reward's energy (joint angles, velocities, appendages,
...); here the two errors are the evaluation's, which a reader can interpret in rad and m.

Outputs (in the experts directory or `--table-out`): `experts.json` (every figure and
curve), `experts.md` (the table) and `experts_tracking.png` (Fig. 3B).
"""
from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np

from actors.character.mirror import MIRROR_SUFFIX
from learner.atomic_io import atomic_write_json, atomic_write_text
from learner.errors import SfvError
from services.training.curves import save_figure

TABLE_JSON, TABLE_MD, TABLE_PNG = "experts.json", "experts.md", "experts_tracking.png"
DEFAULT_EPISODES = 16
DEFAULT_STARTS = 16
CURVE_SECONDS = 4.0
FIGURES = ("normalized_return", "normalized_return_std", "fall_rate", "episode_seconds", "joint_rotation_error_rad",
           "end_effector_error_m", "episodes")


def tracking_curve(expert, env, starts: int = DEFAULT_STARTS, seconds: float = CURVE_SECONDS) -> dict:
    """Fig. 3B for one expert: per control step since initialisation, the mean joint-rotation
    and end-effector errors over the rollouts still running, how many run, and the fraction
    that has had a strict fall."""
    from actors.character.features import RewardFeatures
    from services.training.evaluation import start_phases, strict_fall_detector, tracking_errors

    steps_cap = max(1, int(round(seconds * env.config.control_hz)))
    rotation = np.zeros(steps_cap)
    end_effector = np.zeros(steps_cap)
    running = np.zeros(steps_cap, dtype=np.int64)
    fallen = np.zeros(steps_cap)
    detector = strict_fall_detector(env)
    sim_values = env.features.sim.values
    saved = env.config
    env.config = dataclasses.replace(saved, early_termination=False)
    try:
        for phase in start_phases(starts):
            obs, _ = env.reset(options={"init": "rsi", "phase": float(phase)})
            limit = min(steps_cap, env.max_episode_steps)
            sim_rows, ref_rows, fell = np.empty((limit, sim_values.shape[1])), np.empty(limit, dtype=np.int64), np.zeros(limit)
            has_fallen, steps = False, 0
            for steps in range(1, limit + 1):
                obs, _, terminated, _, _ = env.step(expert.act(obs[None])[0])
                if terminated:  # diverged: MuJoCo reset the state, nothing after it is a rollout
                    steps -= 1
                    break
                sim_rows[steps - 1] = sim_values[0]
                ref_rows[steps - 1] = env.row
                has_fallen = has_fallen or detector(env.data)
                fell[steps - 1] = has_fallen
            if steps:
                # The env's character's reward layout (its joints, its end effectors), not the humanoid's default.
                sim = RewardFeatures(sim_rows[:steps], env.features.reward_shape)
                rot, ee = tracking_errors(sim, env.track.features.take(ref_rows[:steps]))
                rotation[:steps] += rot
                end_effector[:steps] += ee
                running[:steps] += 1
                fallen[:steps] += fell[:steps]
    finally:
        env.config = saved
    alive = np.maximum(running, 1)
    keep = running > 0
    return {"seconds": (np.arange(1, steps_cap + 1) / env.config.control_hz)[keep].tolist(),
            "joint_rotation_error_rad": (rotation / alive)[keep].tolist(),
            "end_effector_error_m": (end_effector / alive)[keep].tolist(),
            "rollouts": running[keep].tolist(), "fallen_fraction": (fallen / alive)[keep].tolist(), "starts": int(starts)}


def evaluate_expert(experts_dir: str, clip: str, episodes: int = DEFAULT_EPISODES, starts: int = DEFAULT_STARTS,
                    curve_seconds: float = CURVE_SECONDS) -> dict:
    """One table row: the strict evaluation and the tracking curve of `clip`'s expert."""
    from threadpoolctl import threadpool_limits

    from services.experts.job import samples_done
    from services.experts.library import load_expert
    from services.training.evaluation import evaluate_policy, make_eval_env

    expert = load_expert(experts_dir, clip, max_batch=1)  # its run's body (config.json's env.character)
    env = make_eval_env(expert.reference(), expert.env_config)
    with threadpool_limits(1, user_api="blas"):  # batch-1 inference: BLAS threads only spin
        figures = evaluate_policy(expert, env, episodes)
        curve = tracking_curve(expert, env, starts, curve_seconds)
    row = {"clip": clip, "motion": expert.motion, "character": expert.env_config.character, **{k: figures[k] for k in FIGURES},
           "survival_rate": 1.0 - figures["fall_rate"], "clip_seconds": env.motion.duration, "loop": env.motion.loop, "curve": curve}
    original = clip.removesuffix(MIRROR_SUFFIX)
    row["samples"] = samples_done(Path(experts_dir) / original)
    if clip != original:
        row["mirror_of"] = original
    return row


def table_clips(experts_dir: Path, mirrors: bool = True) -> list[str]:
    """Every clip with a trained expert in the directory (a subdirectory with a checkpoint),
    each followed by its mirror when its body has mirrored experts (humanoid3d's and the G1's)."""
    from services.experts.library import MIRROR_CHARACTERS, run_character
    from services.training.run_dir import checkpoint_files

    trained = sorted(p.name for p in experts_dir.iterdir() if p.is_dir() and checkpoint_files(p))
    return [c for clip in trained
            for c in ((clip, clip + MIRROR_SUFFIX) if mirrors and run_character(experts_dir / clip) in MIRROR_CHARACTERS else (clip,))]


def build_table(experts_dir: str | Path, clips: list[str] | None = None, episodes: int = DEFAULT_EPISODES,
                starts: int = DEFAULT_STARTS, curve_seconds: float = CURVE_SECONDS, parallel: int = 1,
                progress: bool = True, out: str | Path | None = None) -> dict:
    """Evaluate the experts (one Ray task each when `parallel` > 1, else in this process) and
    write experts.json, experts.md and the Fig. 3B PNG into `out` (default: the experts
    directory). Rows of an earlier experts.json there are kept for experts that have not
    trained since (same samples) and were measured with the same settings, so a table
    grows with the experts instead of re-evaluating them all."""
    from tqdm import tqdm

    from services.experts.job import samples_done
    from services.experts.library import check_mirror, run_character

    experts_dir = Path(experts_dir)
    if not experts_dir.is_dir():
        raise SfvError(f"{experts_dir}: no such experts directory")
    out = experts_dir if out is None else Path(out)
    out.mkdir(parents=True, exist_ok=True)
    clips = clips or table_clips(experts_dir)
    if not clips:
        raise SfvError(f"{experts_dir}: no trained experts (no <clip>/ run directory with a checkpoint)")
    for clip in clips:  # a mirror of a body without mirrored experts: refused here, not inside a task
        original = experts_dir / clip.removesuffix(MIRROR_SUFFIX)
        if clip.endswith(MIRROR_SUFFIX) and (original / "config.json").is_file():
            check_mirror(clip, run_character(original))
    settings = {"experts_dir": str(experts_dir), "episodes": int(episodes), "curve_starts": int(starts), "curve_seconds": float(curve_seconds)}
    earlier = _earlier_rows(out / TABLE_JSON, settings)
    trained = {clip: samples_done(experts_dir / clip.removesuffix(MIRROR_SUFFIX)) for clip in clips}
    kept = {clip: earlier[clip] for clip in clips if clip in earlier and earlier[clip]["samples"] == trained[clip]}
    args = [(str(experts_dir), clip, episodes, starts, curve_seconds) for clip in clips if clip not in kept]
    bar = tqdm(total=len(args), desc="evaluating experts", unit="expert", disable=not progress, dynamic_ncols=True)
    if parallel > 1 and len(args) > 1:
        fresh = _evaluate_with_ray(args, parallel, bar)
    else:
        fresh = []
        for a in args:
            fresh.append(evaluate_expert(*a))
            bar.update(1)
    bar.close()
    by_clip = {**kept, **{row["clip"]: row for row in fresh}}
    rows = [by_clip[clip] for clip in clips]
    for row in rows:  # how far the symmetric expert is from the one it mirrors
        original = by_clip.get(row.get("mirror_of", ""))
        if original is not None:
            row["normalized_return_gap"] = row["normalized_return"] - original["normalized_return"]
    table = {**settings, "experts": rows, "reused": sorted(kept)}
    atomic_write_json(out / TABLE_JSON, table, sort_keys=True)
    atomic_write_text(out / TABLE_MD, markdown_table(table))
    plot_tracking(table, out / TABLE_PNG)
    return table


def _earlier_rows(path: Path, settings: dict) -> dict:
    """{clip: row} of an earlier table measured with the same settings (none otherwise)."""
    try:
        earlier = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    if not isinstance(earlier, dict) or any(earlier.get(k) != v for k, v in settings.items()):
        return {}
    return {row["clip"]: row for row in earlier.get("experts", []) if isinstance(row, dict) and "clip" in row}


def _evaluate_with_ray(args: list[tuple], parallel: int, bar) -> list[dict]:
    import ray

    from services.ray_session import get_results, ray_session

    with ray_session(num_cpus=parallel):
        task = ray.remote(num_cpus=1, max_retries=0)(evaluate_expert)
        refs = [task.remote(*a) for a in args]
        waiting = list(refs)
        while waiting:
            ready, waiting = ray.wait(waiting, num_returns=1)
            bar.update(len(ready))
        return get_results(refs)


def _at(curve: dict, key: str, seconds: float):
    """The curve's value at the step nearest `seconds` since initialisation (None past its end)."""
    times = np.asarray(curve["seconds"])
    if not len(times) or seconds > times[-1] + 1e-9:
        return None
    return float(np.asarray(curve[key])[int(np.argmin(np.abs(times - seconds)))])


def markdown_table(table: dict) -> str:
    fmt = lambda v, spec: "-" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, spec)  # noqa: E731
    characters = sorted({row.get("character", "humanoid3d") for row in table["experts"]})  # rows written before the G1: humanoid3d
    lines = [f"Experts ({', '.join(characters)}) in `{table['experts_dir']}`: {table['episodes']} strict evaluation episodes each; "
             f"tracking error at 1 s and 3 s after initialisation from {table['curve_starts']} starts (Fig. 3B). "
             "Survival: mean seconds before a strict fall or the episode's end (a clip that does not loop ends with the clip); NR - original: a mirrored expert's NR "
             "minus its original's.", "",
             "| clip | samples | NR | fall rate | survival (s) | joint rot. err (rad) | end-eff. err (m) | rot. err @1 s | @3 s | NR - original |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for row in table["experts"]:
        curve = row["curve"]
        lines.append(" | ".join([
            f"| {row['clip']}", f"{row['samples']:,}", fmt(row["normalized_return"], ".3f"), fmt(row["fall_rate"], ".2f"),
            fmt(row["episode_seconds"], ".1f"), fmt(row["joint_rotation_error_rad"], ".3f"), fmt(row["end_effector_error_m"], ".3f"),
            fmt(_at(curve, "joint_rotation_error_rad", 1.0), ".3f"), fmt(_at(curve, "joint_rotation_error_rad", 3.0), ".3f"),
            fmt(row.get("normalized_return_gap"), "+.4f")]) + " |")
    return "\n".join(lines) + "\n"


def plot_tracking(table: dict, out: Path) -> Path:
    """Fig. 3B: joint-rotation and end-effector error against time since initialisation, one
    line per expert (mirrors dotted in their original's colour), the median over experts bold."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), dpi=120)
    originals = sorted({row.get("mirror_of", row["clip"]) for row in table["experts"]})
    colours = {clip: plt.cm.tab20(i % 20) for i, clip in enumerate(originals)}
    for ax, key, label in zip(axes, ("joint_rotation_error_rad", "end_effector_error_m"),
                              ("joint rotation error (rad)", "end-effector error (m)")):
        curves = []
        for row in table["experts"]:
            curve = row["curve"]
            mirror = "mirror_of" in row
            ax.plot(curve["seconds"], curve[key], color=colours[row.get("mirror_of", row["clip"])], lw=1.0,
                    ls=":" if mirror else "-", alpha=0.8, label=None if mirror else row["clip"])
            curves.append(np.asarray(curve[key]))
        longest = max(len(c) for c in curves)
        stacked = np.full((len(curves), longest), np.nan)
        for i, c in enumerate(curves):
            stacked[i, :len(c)] = c
        times = np.arange(1, longest + 1) * (table["experts"][0]["curve"]["seconds"][0])
        ax.plot(times, np.nanmedian(stacked, axis=0), color="black", lw=2.5, label="median")
        ax.set_xlabel("time since initialisation (s)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, ncol=2)
    fig.suptitle(f"Expert tracking from {table['curve_starts']} starts through each clip (dotted: mirrored experts)")
    return save_figure(fig, out)
