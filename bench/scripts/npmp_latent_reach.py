"""What a go-to policy can ask of the motor module: the turn rates and speeds its latent actions reach (issue 47).

    python bench/scripts/npmp_latent_reach.py [--module pretrained] [--directions 16] [--envs 32]
        [--result bench/results/npmp/latent_reach.json]

A go-to policy on the module moves z within the box the task env gives it (`LatentActions`: the
module's posterior centre plus action_k x latent_scale x std_k along its principal directions). What
it can make the walker do is bounded by what the frozen decoder does with those z. From walk and from
run frames (the task envs' starts), each held constant for 4 s (the yaw rate over the last 3 s, the
speed over the last 2.7 s, the task envs' fall rule):
- `centre`: z at the posterior centre;
- `directions`: +-1 along each principal direction alone (the action a policy moves first);
- `random_box`: `--envs` random actions uniform in the box (every direction at once).
A policy cannot turn faster, or walk at another speed, than these reach: they bound the task's success.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # run from a checkout without installing

from actors.envs.tasks.config import TaskEnvConfig  # noqa: E402
from actors.envs.tasks.vector_task_env import VectorTaskEnv  # noqa: E402
from learner.atomic_io import atomic_write_json  # noqa: E402

SECONDS = 4.0
STARTS = ("deepmimic:walk", "deepmimic:run")


def hold(env: VectorTaskEnv, actions: np.ndarray) -> dict:
    """Each env holds its action row for SECONDS from a fresh start: yaw rate, speed, falls."""
    env.rng = np.random.default_rng(0)  # the same starts for every action set
    env.reset()
    hz = env.config.control_hz
    steps = int(SECONDS * hz)
    yaws, xys = np.zeros((steps, env.num_envs)), np.zeros((steps, env.num_envs, 2))
    fell = np.zeros(env.num_envs, bool)
    for t in range(steps):
        env.step(actions)
        fell |= env.terminated
        xy, _, yaw = env.planar_state()
        yaws[t], xys[t] = yaw, xy
    yaws = np.unwrap(yaws, axis=0)
    settle = steps // 4
    rate = np.degrees(yaws[-1] - yaws[settle]) / (SECONDS - settle / hz)
    speed = np.linalg.norm(np.diff(xys[steps // 3:], axis=0), axis=-1).mean(axis=0) * hz
    return {"rate": rate, "speed": speed, "fell": fell}


def summary(held: dict) -> dict:
    ok = ~held["fell"]
    row = {"falls": round(float(held["fell"].mean()), 3)}
    if ok.any():
        for name, unit in (("rate", "yaw_rate_deg_s"), ("speed", "speed_m_s")):
            low, mid, high = np.percentile(held[name][ok], [0, 50, 100])
            row[unit] = {"min": round(float(low), 2), "median": round(float(mid), 2), "max": round(float(high), 2)}
    return row


def measure(module: str, directions: int, envs: int) -> dict:
    out = {}
    for start in STARTS:
        env = VectorTaskEnv(TaskEnvConfig(module=module, latent_directions=directions, start_motion=start), envs, seed=0)
        actions = np.zeros((envs, env.action_dim), np.float32)
        rows = {"centre": summary(hold(env, actions)), "directions": []}
        for k in range(env.action_dim):
            for sign in (-1.0, 1.0):
                actions[:] = 0.0
                actions[:, k] = sign
                rows["directions"].append({"direction": k, "action": sign, **summary(hold(env, actions))})
        actions[:] = np.random.default_rng(1).uniform(-1.0, 1.0, actions.shape)
        rows["random_box"] = summary(hold(env, actions))
        out[start] = rows
        print(start, json.dumps({"centre": rows["centre"], "random_box": rows["random_box"]}), flush=True)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--module", default="pretrained")
    parser.add_argument("--directions", type=int, default=16, help="principal directions held one at a time (the task default uses 8)")
    parser.add_argument("--envs", type=int, default=32)
    parser.add_argument("--result", type=Path, default=Path("bench/results/npmp/latent_reach.json"))
    args = parser.parse_args(argv)
    result = {"what": __doc__.split("\n\n")[0], "module": args.module, "directions": args.directions, "envs": args.envs,
              "seconds": SECONDS, "starts": measure(args.module, args.directions, args.envs)}
    atomic_write_json(args.result, result)
    print(f"wrote {args.result}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
