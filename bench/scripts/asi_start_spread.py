"""How plausible are ASI's starting states? Reward and falls of the first second from them.

SFV initialises each ASI component at the reference state of its phase with the clip's
per-dimension sample std. Whether that spread means anything depends on the coordinates:
this script draws starts from the initial distribution in each state space and std scale,
runs a policy from them for `--seconds` (default: the zero residual action, i.e. PD tracking
of the reference, which needs no training; or a run's policy with --run), and reports the
mean reward per step, the fraction of starts that fall (strict rule) and the mean joint
rotation offset of the start from the reference, against RSI (exact reference states).

    python bench/scripts/asi_start_spread.py --motion deepmimic:walk --out bench/results/asi_start_spread.json
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from actors.envs.falls import FallDetector  # noqa: E402
from actors.envs.imitation_env import EnvConfig, ImitationEnv  # noqa: E402
from actors.motion.formats.io import load_motion  # noqa: E402
from services.asi.distribution import InitialStateDistribution  # noqa: E402
from services.training.run_dir import write_json_atomic  # noqa: E402


def rollout_stats(env: ImitationEnv, starts, policy, seconds: float) -> dict:
    """starts: list of (phase, state or None). Mean reward per step and strict fall rate."""
    fall = FallDetector.for_track(env.humanoid, env.track, env.config.ground_contact_links, strict=True)
    steps = int(round(seconds * env.config.control_hz))
    rewards, falls = [], 0
    zero = np.zeros(env.action_space.shape[0], np.float32)
    for phase, state in starts:
        options = {"phase": phase, "init": "state" if state is not None else "rsi"}
        if state is not None:
            options["state"] = state
        obs, _ = env.reset(seed=0, options=options)
        total, n = 0.0, 0
        for _ in range(steps):
            action = zero if policy is None else policy.act(obs[None], deterministic=True)[0][0]
            obs, reward, terminated, truncated, _ = env.step(action)
            total += reward
            n += 1
            if fall(env.data):
                falls += 1
                break
            if terminated or truncated:
                break
        rewards.append(total / steps)  # a fall forfeits the rest of the window
    return {"reward_per_step": float(np.mean(rewards)), "fall_rate": falls / len(starts)}


def asi_starts(env: ImitationEnv, scale: float, count: int, rng) -> list:
    rows = np.arange(env.track.start_steps)
    states = np.stack([env.reference_state_vector(r) for r in rows])
    dist = InitialStateDistribution.from_reference(states, env.track.phase[rows], num_components=10)
    dist = InitialStateDistribution(dist.phases, dist.means, dist.log_stds + np.log(scale))
    sampled, components = dist.sample(rng, count)
    return [(float(dist.phases[c]), s.astype(np.float64)) for s, c in zip(sampled, components)]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--motion", default="deepmimic:walk")
    p.add_argument("--starts", type=int, default=200, help="starts per setting")
    p.add_argument("--seconds", type=float, default=1.0)
    p.add_argument("--scales", default="1,0.5,0.25,0.1", help="std scales to try, comma-separated")
    p.add_argument("--run", default=None, help="a run directory whose policy acts (default: zero residual action)")
    p.add_argument("--out", default=None, help="JSON file for the results")
    args = p.parse_args(argv)
    policy = None
    if args.run:
        from learner.policy import NumpyPolicy
        from services.training.run_dir import load_run

        _, weights = load_run(args.run)
        policy = NumpyPolicy(weights, max_batch=1)
    motion = load_motion(args.motion)
    rng = np.random.default_rng(0)
    results = []
    base = EnvConfig(early_termination=False)
    env = ImitationEnv(motion, base)
    rsi = [(float(p), None) for p in rng.uniform(0, 1, args.starts)]
    results.append({"init": "rsi", "space": None, "scale": None, **rollout_stats(env, rsi, policy, args.seconds)})
    print(json.dumps(results[-1]))
    for space in ("qpos", "rotvec"):
        env = ImitationEnv(motion, dataclasses.replace(base, state_space=space))
        for scale in (float(s) for s in args.scales.split(",")):
            stats = rollout_stats(env, asi_starts(env, scale, args.starts, rng), policy, args.seconds)
            results.append({"init": "asi", "space": space, "scale": scale, **stats})
            print(json.dumps(results[-1]))
    if args.out:
        write_json_atomic(Path(args.out), {"motion": args.motion, "policy": args.run or "zero residual action",
                                           "seconds": args.seconds, "starts": args.starts, "results": results})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
