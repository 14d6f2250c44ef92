"""Does a policy keep its skill at another physics rate? The same policy evaluated at several rates.

`mj_step` is about three quarters of a rollout worker's time at 300 Hz, so the physics rate
sets the training throughput. A rate is cheap enough only if a policy trained there keeps its
normalised return when the physics is finer (300 Hz, 1.2 kHz, the paper's Bullet rate): this
script loads a run's best policy and runs `sfv eval`'s strict evaluation with the run's env
settings at each `--hz`, one line and one JSON row per rate.

    python bench/scripts/physics_rate.py runs/walk_150 --hz 150,300,1200 --out bench/results/physics_rate_walk.json
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from learner.errors import SfvError  # noqa: E402
from services.training.evaluation import evaluate_policy, make_eval_env, with_physics_rate  # noqa: E402
from services.training.policy_source import load_policy_source  # noqa: E402
from services.training.run_dir import write_json_atomic  # noqa: E402


def evaluate_at_rates(run: str, rates: list[float], episodes: int, seed: int = 0) -> list[dict]:
    """One strict evaluation of the run's policy per physics rate (the rest of its env unchanged)."""
    from threadpoolctl import threadpool_limits

    source = load_policy_source(run)
    motion = source.reference()
    rows = []
    for hz in rates:
        config = with_physics_rate(source.env_config, hz, flag="--hz")
        started = time.perf_counter()
        with threadpool_limits(1, user_api="blas"):
            result = evaluate_policy(source.policy, make_eval_env(motion, config), episodes, seed)
        rows.append({"physics_hz": hz, "trained_hz": source.env_config.physics.physics_hz,
                     "seconds": round(time.perf_counter() - started, 1),
                     **{k: result[k] for k in ("normalized_return", "fall_rate", "episode_seconds", "joint_rotation_error_rad")}})
        print(f"{hz:g} Hz: NR {result['normalized_return']:.3f}, falls {result['fall_rate']:.2f}, "
              f"{result['episode_seconds']:.1f} s survived", flush=True)
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", help="run directory (its best checkpoint)")
    parser.add_argument("--hz", default="150,300,1200", help="physics rates, comma-separated (multiples of the control rate)")
    parser.add_argument("--episodes", type=int, default=32)
    parser.add_argument("--out", help="JSON file to write")
    args = parser.parse_args(argv)
    try:
        rates = [float(x) for x in args.hz.split(",") if x.strip()]
    except ValueError:
        print(f"error: --hz must be numbers separated by commas, got {args.hz!r}", file=sys.stderr)
        return 2
    try:
        rows = evaluate_at_rates(args.run, rates, args.episodes)
    except SfvError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    if args.out:
        write_json_atomic(Path(args.out), {"run": str(args.run), "episodes": args.episodes, "rates": rows})
        print(json.dumps({"wrote": args.out}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
