"""Why does a terrain walk fall on gaps and steps? Issue 49: two measurements on a trained run.

    python bench/scripts/terrain_diagnosis.py feet RUN --terrain steps --difficulty 0.5
    python bench/scripts/terrain_diagnosis.py falls RUN --terrain gaps --difficulty 0.5 [--episodes 12]

- `feet`: the reference's feet as the env plays them over the ground (`Ground.follow` lifts the
  clip by the support under its root), against the ground under each foot: over 8 terrains of
  seed 1000, the share of stance frames (a foot's lowest point within 2 cm of the clip's floor)
  over a trench, and how far the lifted sole is from the ground under it. A reference that puts
  its feet into risers or trenches would pay the policy for tripping.
- `falls`: the run's latest policy, deterministic, from evenly spaced phases; at the first strict
  fall, which links touch the ground and how high the pelvis stands above the support, then the
  lowest the pelvis goes over the next 1.5 s (early termination off). A stumble the rule calls a
  fall would stay up; a real fall goes down.
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

SEED = 1000
AFTER_S = 1.5


def terrain_env(run: str, kind: str, difficulty: float):
    from services.training.evaluation import make_eval_env
    from services.training.policy_source import load_policy_source

    source = load_policy_source(run, None, None, "latest")
    config = dataclasses.replace(source.env_config, terrain=kind, terrain_difficulty=difficulty, terrain_seed=SEED,
                                 terrain_curriculum=False)
    return source, make_eval_env(source.reference(), config)


def feet(run: str, kind: str, difficulty: float, stance_m: float = 0.02) -> dict:
    import mujoco

    from actors.arenas.height_lookup import HeightQuery
    from actors.envs.ground_facts import _lowest_z

    _, env = terrain_env(run, kind, difficulty)
    model, data = env.model, mujoco.MjData(env.model)
    character = env.humanoid.character
    feet_geoms = [[g for g in range(model.ngeom) if model.geom_bodyid[g] == env.humanoid.body_ids[character.link_names.index(f)]]
                  for f in character.feet]
    gaps, trench, frames = [], 0, 0
    for k in range(8):
        env.reset(seed=k, options={"init": "rsi", "phase": 0.0})
        ground = env.ground
        query = HeightQuery(ground.heights, ground.arena.frame, ground.arena.grid, 1)
        for row in range(0, env.track.qpos.shape[0], 2):
            data.qpos[:] = env.track.qpos[row]
            mujoco.mj_kinematics(model, data)
            lift = ground.support_at(0, data.qpos[:2])
            for geoms in feet_geoms:
                lowest = min(_lowest_z(model, data, g) for g in geoms)
                if lowest > stance_m:
                    continue
                frames += 1
                under = float(query(data.xpos[model.geom_bodyid[geoms[0]], :2].reshape(1, 1, 2))[0, 0])
                if under < -0.3:
                    trench += 1
                else:
                    gaps.append(lowest + lift - under)
    gaps = np.asarray(gaps)
    return {"terrain": kind, "difficulty": difficulty, "stance_foot_frames": frames, "over_a_trench": round(trench / frames, 3),
            "mean_abs_gap_cm": round(float(np.abs(gaps).mean() * 100), 1), "below_ground_3cm": round(float(np.mean(gaps < -0.03)), 3),
            "above_ground_3cm": round(float(np.mean(gaps > 0.03)), 3)}


def falls(run: str, kind: str, difficulty: float, episodes: int) -> dict:
    from services.training.evaluation import start_phases, strict_fall_detector

    source, env = terrain_env(run, kind, difficulty)
    detector, names = strict_fall_detector(env), env.humanoid.character.link_names
    after_steps = int(round(AFTER_S * env.config.control_hz))
    rows = []
    for k, phase in enumerate(start_phases(episodes)):
        obs, _ = env.reset(seed=k, options={"init": "rsi", "phase": float(phase)})
        batch = np.zeros((1, obs.shape[0]), np.float32)
        batch[0] = obs
        fell_at, support, lowest, touching, root = None, 0.0, np.inf, [], 0.0
        for t in range(env.max_episode_steps):
            obs, _, terminated, truncated, _ = env.step(source.policy.mean(batch)[0])
            batch[0] = obs
            if terminated or truncated:
                break
            if fell_at is None and detector(env.data):
                fell_at, mask = t, detector.touching(env.data)
                touching = [names[i] for i in range(len(names)) if mask >> i & 1]
                support = env.ground.support_at(0, env.data.qpos[:2])
                root = float(env.data.qpos[2]) - support
            elif fell_at is not None:
                lowest = min(lowest, float(env.data.qpos[2]) - support)
                if t - fell_at >= after_steps:
                    break
        if fell_at is not None:
            rows.append({"episode": k, "fell_at_s": round(fell_at / env.config.control_hz, 2), "links": touching,
                         "pelvis_above_support_m": round(root, 2), "lowest_after_m": round(lowest, 2)})
    return {"terrain": kind, "difficulty": difficulty, "episodes": episodes, "fell": len(rows), "falls": rows}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("what", choices=("feet", "falls"))
    parser.add_argument("run")
    parser.add_argument("--terrain", default="steps")
    parser.add_argument("--difficulty", type=float, default=0.5)
    parser.add_argument("--episodes", type=int, default=12)
    args = parser.parse_args(argv)
    import json

    result = feet(args.run, args.terrain, args.difficulty) if args.what == "feet" else \
        falls(args.run, args.terrain, args.difficulty, args.episodes)
    print(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
