"""Which ASI components does a trained policy fail from? Exact and noisy starts per component.

`sfv eval`'s fall_starts name the phases a policy falls from, but training starts episodes at
ASI's k component phases, drawn around each component's mean with its std. A component whose
every start falls within a second gives PPO only short failed episodes there, so a plateau can
hide a phase the policy has never learned to start from. For each component this runs the
run's best policy (deterministic, strict falls) from the reference state at the component's
phase and from `--draws` states drawn from the run's initial ASI distribution (the reference
states with `asi_initial_std_scale` x the clip's per-dimension std, the distribution a run
starts with; ASI's later steps move it by under 1 % of sigma), each for `--seconds`.

Measured (dance_b at 11 M samples): only the component at phase .4 fails, the exact start
after 22 control steps and all 12 draws, which is where `sfv eval`'s starts .37-.47 fall.

    python bench/scripts/asi_component_starts.py RUN [--draws 12] [--seconds 2] [--out F.json]
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from services.asi.distribution import InitialStateDistribution  # noqa: E402
from services.training.evaluation import make_eval_env, strict_fall_detector  # noqa: E402
from services.training.policy_source import load_policy_source  # noqa: E402
from services.training.run_dir import write_json_atomic  # noqa: E402


def steps_to_fall(env, detector, policy, options: dict, steps: int) -> int | None:
    """Control steps until the strict fall rule fires, None if it does not within `steps`."""
    obs, _ = env.reset(seed=0, options=options)
    for n in range(steps):
        obs, *_ = env.step(policy.mean(obs[None].astype(np.float32))[0])
        if detector(env.data):
            return n + 1
    return None


def component_starts(run: str, draws: int, seconds: float, seed: int = 0) -> list[dict]:
    source = load_policy_source(run, None, None, "best")
    env = make_eval_env(source.reference(), source.env_config)
    detector = strict_fall_detector(env)
    config = json.loads((Path(run) / "config.json").read_text())
    rows = np.arange(env.track.start_steps)
    states = np.stack([env.reference_state_vector(r) for r in rows])
    dist = InitialStateDistribution.from_reference(states, env.track.phase[rows], num_components=int(config.get("asi_components", 10)))
    stds = np.exp(dist.log_stds) * float(config.get("asi_initial_std_scale", 0.1))
    steps = int(round(seconds * env.config.control_hz))
    rng = np.random.default_rng(seed)
    out = []
    for c, phase in enumerate(dist.phases):
        exact = steps_to_fall(env, detector, source.policy, {"init": "rsi", "phase": float(phase)}, steps)
        drawn = [steps_to_fall(env, detector, source.policy,
                               {"init": "state", "phase": float(phase),
                                "state": (dist.means[c] + stds[c] * rng.standard_normal(dist.means.shape[1])).astype(np.float64)}, steps)
                 for _ in range(draws)]
        out.append({"component": c, "phase": round(float(phase), 3), "exact_fell_after_steps": exact,
                    "drawn_falls": sum(d is not None for d in drawn), "draws": draws})
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("run", help="a run directory (its best.pt and config.json)")
    p.add_argument("--draws", type=int, default=12, help="states drawn per component")
    p.add_argument("--seconds", type=float, default=2.0, help="length of each start's window")
    p.add_argument("--out", default=None, help="JSON file for the results")
    args = p.parse_args(argv)
    if args.draws < 0 or not args.seconds > 0:
        p.error("--draws must be >= 0 and --seconds positive")
    results = component_starts(args.run, args.draws, args.seconds)
    for row in results:
        print(json.dumps(row))
    if args.out:
        write_json_atomic(Path(args.out), {"run": args.run, "seconds": args.seconds, "components": results})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
