"""Is a clip's flight physically consistent on our body? Angular momentum and CoM fall in the air.

Once nothing touches the ground, physics fixes the character's angular momentum about its centre
of mass and makes the centre of mass fall at g. A reference state taken mid-flight (an RSI, ASI
or `sfv eval` start there) carries the momentum the reference's kinematic velocities give on our
body's masses; if that momentum changes along the reference's own flight, a start at one flight
phase cannot reach the reference's landing, whatever the policy does (limbs can redistribute
rotation, not create it). For each start row of one pass of the clip: airborne (no contact with
the ground in the reference pose), the whole-body angular momentum about the CoM (kg m^2/s,
world frame) and the CoM's vertical velocity; per airborne stretch, how far the momentum moves
against its mean and the CoM's vertical acceleration against -9.81 m/s^2. A stretch whose CoM does
not fall at about g is a reference hovering its feet over the floor, not a flight (the jump's and
the cartwheel's standing rows): read the acceleration before the momentum. Per flight also the
momentum ballistic start states get (`actors/motion/ballistic_flight.py`, L*), and with `--run DIR`
the momentum the run's policy carries through its own flight from the clip's first frame.

    python bench/scripts/flight_momentum.py --clips backflip,spin,jump --run runs/backflip --out bench/results/acrobatics/flight_momentum.json
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import mujoco
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from actors.envs.imitation_env import EnvConfig, ImitationEnv  # noqa: E402
from actors.motion.ballistic_flight import ballistic_start_velocities  # noqa: E402
from actors.motion.formats.io import load_motion  # noqa: E402
from services.training.run_dir import write_json_atomic  # noqa: E402


def reference_flight(clip: str) -> dict:
    env = ImitationEnv(load_motion(f"deepmimic:{clip}"), EnvConfig(flight_starts="reference"))  # the clip's own velocities
    model, data, track = env.model, env.data, env.track
    root = 1  # the character's root body: its subtree is the whole body
    rows = track.start_steps
    airborne = np.zeros(rows, bool)
    momentum = np.zeros((rows, 3))
    com_vz = np.zeros(rows)
    for row in range(rows):
        data.qpos[:] = track.qpos[row]
        data.qvel[:] = track.reference_qvel[row]
        mujoco.mj_forward(model, data)
        mujoco.mj_subtreeVel(model, data)
        airborne[row] = data.ncon == 0
        momentum[row] = data.subtree_angmom[root]
        com_vz[row] = data.subtree_linvel[root, 2]
    dt = track.dt
    stretches = []
    edges = np.flatnonzero(np.diff(np.concatenate(([0], airborne.astype(int), [0]))))
    for a, b in zip(edges[::2], edges[1::2]):
        if b - a < 3:
            continue
        h = momentum[a:b]
        mean = h.mean(axis=0)
        stretches.append({
            "phases": [round(float(track.phase[a]), 3), round(float(track.phase[b - 1]), 3)],
            "seconds": round((b - a) * dt, 3),
            "angular_momentum_mean": np.round(mean, 2).tolist(),
            "angular_momentum_norm_first_last": [round(float(np.linalg.norm(h[0])), 2), round(float(np.linalg.norm(h[-1])), 2)],
            "angular_momentum_change_over_mean_norm": round(float(np.linalg.norm(h - mean, axis=1).max() / max(np.linalg.norm(mean), 1e-9)), 3),
            "com_vertical_acceleration": round(float(np.polyfit(np.arange(b - a) * dt, com_vz[a:b], 1)[0]), 2),
        })
    _, ballistic = ballistic_start_velocities(model, track.qpos[:rows], track.reference_qvel[:rows], dt)
    return {"clip": clip, "start_rows": int(rows),
            "ballistic_flights": [{"phases": [round(float(track.phase[f.rows[0]]), 3), round(float(track.phase[f.rows[1]]), 3)],
                                   "angular_momentum_norm": round(f.momentum_after, 2)} for f in ballistic.flights],
            "airborne_rows": int(airborne.sum()), "flights": stretches,
            "angular_momentum_norm_per_row": np.round(np.linalg.norm(momentum, axis=1), 2).tolist(),
            "airborne_per_row": airborne.astype(int).tolist()}


def policy_flight(run_dir: str, steps: int = 150) -> dict:
    """The run's best policy from the clip's first frame, deterministic: |L| about the centre of mass
    and contact per control step while nothing touches the ground."""
    from services.training.policy_source import load_policy_source

    source = load_policy_source(run_dir)
    env = source.make_env()
    obs, _ = env.reset(options={"init": "rsi", "phase": 0.0})
    model, data = env.model, env.data
    airborne = []
    for _ in range(steps):
        obs, _, terminated, truncated, _ = env.step(source.policy.mean(obs[None]).reshape(-1))
        mujoco.mj_subtreeVel(model, data)
        if data.ncon == 0:
            airborne.append([round(env.phase, 3), round(float(np.linalg.norm(data.subtree_angmom[1])), 2)])
        if terminated or truncated:
            break
    return {"run": str(run_dir), "motion": source.motion, "airborne_phase_and_angular_momentum_norm": airborne}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clips", default="backflip,spin,jump")
    parser.add_argument("--run", default=None, help="also a trained run's own flight from the first frame")
    parser.add_argument("--out", required=True)
    args = parser.parse_args(argv)
    results = [reference_flight(c.strip()) for c in args.clips.split(",") if c.strip()]
    for r in results:
        for f in r["flights"]:
            print(f"{r['clip']}: airborne at phases {f['phases'][0]}-{f['phases'][1]} ({f['seconds']} s): angular momentum "
                  f"{f['angular_momentum_norm_first_last'][0]} -> {f['angular_momentum_norm_first_last'][1]} kg m^2/s "
                  f"(moves {f['angular_momentum_change_over_mean_norm']:.0%} of its mean), CoM vertical acceleration "
                  f"{f['com_vertical_acceleration']} m/s^2 (physics: -9.81)")
        for f in r["ballistic_flights"]:
            print(f"{r['clip']}: ballistic starts at phases {f['phases'][0]}-{f['phases'][1]} carry {f['angular_momentum_norm']} kg m^2/s")
    report = {"note": __doc__.split("\n\n")[1], "clips": results}
    if args.run:
        report["policy"] = policy_flight(args.run)
        flight = [L for p, L in report["policy"]["airborne_phase_and_angular_momentum_norm"] if L > 10]
        if flight:
            print(f"{args.run}: its own flights carry {min(flight)}-{max(flight)} kg m^2/s")
    write_json_atomic(args.out, report)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
