"""Pure PD tracking of each clip (zero residual action): how long it survives and how far it drifts.

What a policy starts from. For each clip and each setting, episodes start at evenly spaced
phases from the reference state (or from a draw of ASI's initial distribution at --asi-std x
the clip's per-dimension std) and run with the zero action, so the PD targets are the
reference's (`--lead` control steps after the step acted towards, the `target_lead_s` setting).
Reported per clip and setting: control steps survived (early termination as in training, at
most --steps), the reward terms averaged over the first --terms-steps steps, and the root's
heading error after --heading-steps steps (the turn PD control alone does not follow).

    python bench/scripts/pd_tracking.py --clips walk,dance_a,spinkick,backflip --leads 0,2 --asi-stds 0,0.1,0.25 \\
        --out bench/results/pd_tracking.json
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from actors.character import quaternion as qn  # noqa: E402
from actors.envs.imitation_env import EnvConfig, ImitationEnv  # noqa: E402
from actors.motion.formats.io import load_motion  # noqa: E402
from learner.errors import SfvError  # noqa: E402
from services.asi.distribution import InitialStateDistribution  # noqa: E402
from services.training.evaluation import with_physics_rate  # noqa: E402
from services.training.run_dir import write_json_atomic  # noqa: E402


def heading_error(env: ImitationEnv) -> float:
    """|yaw of the character's root - yaw of the reference's| in [0, pi]."""
    d = qn.heading_angle(env.data.qpos[3:7]) - qn.heading_angle(env.track.qpos[env.row, 3:7])
    return float(abs((d + np.pi) % (2 * np.pi) - np.pi))


def track(env: ImitationEnv, starts: list[dict], steps: int, terms_steps: int, heading_steps: int) -> dict:
    survived, terms, headings = [], [], []
    zero = np.zeros(env.action_space.shape, np.float32)
    for options in starts:
        env.reset(seed=0, options=options)
        n = 0
        while n < steps:
            _, _, terminated, truncated, _ = env.step(zero)
            n += 1
            if n <= terms_steps:
                terms.append(env.reward_terms.copy())
            if n == heading_steps:
                headings.append(heading_error(env))
            if terminated or truncated:
                break
        survived.append(n)
    return {"steps_survived": round(float(np.mean(survived)), 2),
            "reward_terms": dict(zip(env.reward_term_names, np.round(np.mean(terms, axis=0), 4).tolist())),
            "heading_error_rad": round(float(np.mean(headings)), 4) if headings else None}


def starts_for(env: ImitationEnv, episodes: int, asi_std: float, rng: np.random.Generator) -> list[dict]:
    """Reference states at evenly spaced phases, or ASI draws (component k mod 10) at asi_std x the clip's std."""
    if asi_std <= 0:
        return [{"init": "rsi", "phase": k / episodes} for k in range(episodes)]
    rows = np.arange(env.track.start_steps)
    states = np.stack([env.reference_state_vector(r) for r in rows])
    dist = InitialStateDistribution.from_reference(states, env.track.phase[rows], 10)
    stds = dist.stds * asi_std
    out = []
    for k in range(episodes):
        c = k % dist.num_components
        out.append({"init": "state", "phase": float(dist.phases[c]), "state": dist.means[c] + rng.standard_normal(dist.state_dim) * stds[c]})
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clips", default="walk,dance_a,spinkick,backflip", help="DeepMimic clips or motion files, comma-separated")
    parser.add_argument("--leads", default="0,2", help="residual base leads in control steps (target_lead_s x control rate)")
    parser.add_argument("--physics-hz", default="300", help="physics rates, comma-separated (whole multiples of the 30 Hz control rate)")
    parser.add_argument("--asi-stds", default="0", help="start spreads: 0 = reference states, else ASI at this x the clip's std")
    parser.add_argument("--episodes", type=int, default=30)
    parser.add_argument("--steps", type=int, default=90, help="at most this many control steps an episode")
    parser.add_argument("--terms-steps", type=int, default=15)
    parser.add_argument("--heading-steps", type=int, default=15)
    parser.add_argument("--out", help="JSON file to write")
    args = parser.parse_args(argv)
    try:
        leads = [int(x) for x in args.leads.split(",")]
        spreads = [float(x) for x in args.asi_stds.split(",")]
        rates = [float(x) for x in args.physics_hz.split(",")]
        if any(x < 0 for x in leads + spreads) or any(x <= 0 for x in rates):
            raise ValueError
    except ValueError:
        print("error: --leads must be integers >= 0, --asi-stds numbers >= 0 and --physics-hz rates > 0, comma-separated", file=sys.stderr)
        return 2
    rows = []
    try:
        for clip in [c.strip() for c in args.clips.split(",") if c.strip()]:
            motion = load_motion(clip if ":" in clip or "/" in clip or "." in clip else f"deepmimic:{clip}")
            for lead, rate in [(lead, rate) for lead in leads for rate in rates]:
                config = EnvConfig()
                config = with_physics_rate(dataclasses.replace(config, target_lead_s=lead / config.control_hz), rate)
                env = ImitationEnv(motion, config)
                for spread in spreads:
                    result = track(env, starts_for(env, args.episodes, spread, np.random.default_rng(0)),
                                   args.steps, args.terms_steps, args.heading_steps)
                    rows.append({"clip": motion.name, "lead_steps": lead, "physics_hz": rate, "asi_std": spread, **result})
                    print(f"{motion.name} lead {lead} {rate:g} Hz asi {spread:g}: {result['steps_survived']:.1f} steps, "
                          f"end effector term {result['reward_terms']['end_effector']:.2f}, "
                          f"heading off {result['heading_error_rad']} rad", flush=True)
    except SfvError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    if args.out:
        write_json_atomic(Path(args.out), {"episodes": args.episodes, "steps": args.steps, "terms_steps": args.terms_steps,
                                           "heading_steps": args.heading_steps, "rows": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
