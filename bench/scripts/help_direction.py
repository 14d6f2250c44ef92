"""What does the residual root force do for a pipeline's controller? Issue 44: why the body falls
without it.

    python bench/scripts/help_direction.py RUN [RUN ...] [--out bench/results/help_direction.json]

RUN is an `sfv pipeline` output directory (motion.npz, train/). Its best controller is played from
the clip's first frame as `report.json`'s episode is (`services/pipeline/rollout.py`), and at each
control step the wrench the controller puts on its pelvis is read in world axes
(`MjData.xfrc_applied`, the step's last substep). Split, as fractions of body weight (torque: of
body weight x 0.5 m, `actors/envs/residual_force.ARM_M`):

- up / down: the vertical force (holding the body up, or pressing it down);
- along / across: the horizontal force along the reference root's direction of travel, and across it;
- torque: its size;

each over all steps and over the steps in each of the reference's contact phases (both feet, one,
none, from the contact estimate in motion.npz), and the ten steps of most help with their frame.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

RESULT = REPO / "bench" / "results" / "help_direction.json"


def wrench_rollout(run: Path) -> dict:
    from actors.envs.residual_force import ARM_M
    from actors.motion.formats.io import load_motion
    from services.training.evaluation import make_eval_env
    from services.training.policy_source import load_policy_source

    reconstruction = load_motion(str(run / "motion.npz"))
    source = load_policy_source(run / "train")
    env = make_eval_env(reconstruction, source.env_config)
    residual = env.core.residual
    if residual is None:
        raise SystemExit(f"{run}: trained without a residual root force")
    root = residual.root_body
    weight = residual.weight_n
    obs, _ = env.reset(seed=0, options={"init": "fsi"})
    limit = min(env.max_episode_steps, env.track.start_steps)
    forces, torques, rows, heights = [], [], [], []
    for _ in range(limit):
        row = obs[None].astype(np.float32)
        mean = getattr(source.policy, "mean", None)
        action = mean(row) if callable(mean) else source.policy.act(row, deterministic=True)[0]
        obs, _, terminated, _, _ = env.step(np.asarray(action)[0])
        if terminated:
            break
        forces.append(env.data.xfrc_applied[root, :3] / weight)
        torques.append(np.linalg.norm(env.data.xfrc_applied[root, 3:]) / (weight * ARM_M))
        rows.append(env.row)
        heights.append(env.data.qpos[2])
    return {"forces": np.array(forces), "torques": np.array(torques), "rows": np.array(rows),
            "root_height": np.array(heights), "reference": reconstruction}


def parts(forces: np.ndarray, torques: np.ndarray, travel: np.ndarray) -> dict:
    along = np.einsum("ti,ti->t", forces[:, :2], travel)
    across = np.abs(travel[:, 0] * forces[:, 1] - travel[:, 1] * forces[:, 0])
    return {"steps": int(len(forces)), "up": round(float(np.clip(forces[:, 2], 0, None).mean()), 4),
            "down": round(float(np.clip(-forces[:, 2], 0, None).mean()), 4),
            "vertical_mean": round(float(forces[:, 2].mean()), 4),
            "along_mean": round(float(along.mean()), 4), "along_abs": round(float(np.abs(along).mean()), 4),
            "across": round(float(across.mean()), 4), "torque": round(float(torques.mean()), 4),
            "size": round(float(np.linalg.norm(forces, axis=1).mean()), 4)}


def analyse(run: Path) -> dict:
    played = wrench_rollout(run)
    forces, torques, rows, motion = played["forces"], played["torques"], played["rows"], played["reference"]
    root = np.asarray(motion.root_pos)
    velocity = np.gradient(root[:, :2], axis=0)
    direction = velocity[rows] / np.maximum(np.linalg.norm(velocity[rows], axis=1, keepdims=True), 1e-9)
    result = {"run": str(run), "all": parts(forces, torques, direction)}
    contacts = motion.extras.get("contacts")
    if contacts is not None:
        down = np.asarray(contacts, bool)[rows].sum(axis=1)
        for count, name in ((2, "both_feet"), (1, "one_foot"), (0, "no_foot")):
            chosen = down == count
            if chosen.any():
                result[name] = parts(forces[chosen], torques[chosen], direction[chosen])
    size = np.linalg.norm(forces, axis=1)
    top = np.argsort(size)[::-1][:10]
    result["most_help"] = [{"step": int(s), "frame": int(rows[s]), "force": np.round(forces[s], 3).tolist(),
                            "feet_down": None if contacts is None else np.asarray(contacts, bool)[rows[s]].tolist()}
                           for s in sorted(top)]
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--out", type=Path, default=RESULT)
    args = parser.parse_args(argv)
    results = []
    for run in args.runs:
        result = analyse(run)
        results.append(result)
        print(json.dumps({k: v for k, v in result.items() if k != "most_help"}), flush=True)
    from learner.atomic_io import atomic_write_json
    atomic_write_json(args.out, results)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
