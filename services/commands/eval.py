"""`sfv eval RUN`: one JSON object with the policy's strict evaluation.

    sfv eval RUN [--episodes 32] [--push N [--push-impulse J] [--push-duration T]] [--seed K]
    sfv eval [RUN] --onnx policy.onnx [--motion deepmimic:walk]   (no torch)
    sfv eval RUN --terrain mixed --terrain-difficulty 1 --terrain-seed 1000   (ground it never saw)

Deterministic episodes (the policy's mean) start at evenly spaced phases of the clip (episode
k of E at phase k/E, from the reference's full state there). Falls are always judged by the
clip's strict rule after every control step, whatever the training's early termination was:
DeepMimic's contact rule (any link but the feet, and those the clip allows, on the ground)
plus a pelvis-height floor. Keys: normalized_return (+ _std), fall_rate, episode_length,
episode_seconds, joint_rotation_error_rad, end_effector_error_m, distance_ratio (looped clips),
divergences, episodes, fall_phases, fall_starts, start_returns
(each episode's start phase and normalized return; the starts under half the median are also
named in one line on stderr); with --push: pushes, push_impulse_ns, push_duration_s, push_episodes,
push_survival_rate; for a clip that does not loop, first_frame: the episode from the clip's first
frame to its end (normalized_return, fell, episode_seconds, clip_seconds, joint and end-effector
errors), also said in one line on stderr beside the phase average. `services/training/evaluation.py`
defines each.
"""
from __future__ import annotations

import argparse
import json
import math
import sys

from services.commands._terrain_args import add_terrain_args, terrain_change

# The same numbers as services.training.evaluation's (imported lazily: every sfv command builds this parser).
DEFAULT_EPISODES = 32
PUSH_HELP = ("push the character N times an episode: an impulse of --push-impulse N s on the pelvis, spread evenly "
             "over the episode (services/training/evaluation.py); adds push_survival_rate")


HELP = "evaluate a trained policy with strict falls (prints one JSON object)"  # the one line `sfv --help` lists (without importing the command)


def register(sub) -> None:
    p = sub.add_parser("eval", help=HELP,
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("run", nargs="?", default=None, help="run directory (its best policy, see --checkpoint); optional with --onnx")
    # Numbers are parsed here, not by argparse, so that a bad value is one line naming the flag.
    p.add_argument("--episodes", default=str(DEFAULT_EPISODES), metavar="E",
                   help=f"episodes, started at evenly spaced phases of the clip (default {DEFAULT_EPISODES})")
    p.add_argument("--push", default="0", metavar="N", help=PUSH_HELP)
    p.add_argument("--push-impulse", default="40", metavar="J",
                   help="impulse of one push in N s (default 40: ~0.9 m/s on the 45 kg character)")
    p.add_argument("--push-duration", default="0.1", metavar="T",
                   help="seconds one push acts (default 0.1 = 3 control steps at 30 Hz)")
    p.add_argument("--seed", default="0", metavar="K", help="episode k uses seed + k (push directions and times)")
    p.add_argument("--onnx", default=None, help="evaluate an exported ONNX policy instead of the checkpoint (no torch)")
    p.add_argument("--checkpoint", choices=("best", "latest"), default="best",
                   help="best: best.pt, the best periodic evaluation (the newest checkpoint when the run has none); latest: the newest checkpoint")
    p.add_argument("--motion", default=None, help="motion to evaluate on (default: the run's); required for --onnx without a run")
    p.add_argument("--physics-hz", default=None, metavar="HZ",
                   help="simulate at this physics rate instead of the run's (a whole multiple of its control rate): "
                        "does a policy trained at a cheaper rate keep its return at 300 Hz or 1.2 kHz?")
    add_terrain_args(p)
    p.set_defaults(handler=run)


def _integer(flag: str, text: str, minimum: int | None = None) -> int:
    from learner.errors import SfvError

    try:
        value = int(text)
    except ValueError:
        raise SfvError(f"eval: {flag} must be an integer, got {text!r}") from None
    if minimum is not None and value < minimum:
        raise SfvError(f"eval: {flag} must be {'positive' if minimum == 1 else f'>= {minimum}'}, got {value}")
    return value


def _number(flag: str, text: str, positive: bool) -> float:
    from learner.errors import SfvError

    try:
        value = float(text)
    except ValueError:
        raise SfvError(f"eval: {flag} must be a number, got {text!r}") from None
    if not math.isfinite(value) or value < 0 or (positive and value == 0):
        raise SfvError(f"eval: {flag} must be a finite number {'> 0' if positive else '>= 0'}, got {text}")
    return value


def run(args) -> int:
    from learner.errors import SfvError
    from services.training.evaluation import evaluate_run

    episodes = _integer("--episodes", args.episodes, 1)
    pushes = _integer("--push", args.push, 0)
    impulse = _number("--push-impulse", args.push_impulse, positive=False)
    duration = _number("--push-duration", args.push_duration, positive=True)
    seed = _integer("--seed", args.seed)
    physics_hz = None if args.physics_hz is None else _number("--physics-hz", args.physics_hz, positive=True)
    if args.run is None and args.onnx is None:
        raise SfvError("eval: give a run directory or --onnx FILE")
    result = evaluate_run(args.run, episodes, seed, onnx=args.onnx, motion=args.motion, pushes=pushes,
                          push_impulse=impulse, push_duration_s=duration, checkpoint=args.checkpoint,
                          physics_hz=physics_hz, env_change=terrain_change(args, "eval"))
    if "first_frame" in result:
        print(result_line(result), file=sys.stderr)
    weak = weak_starts_line(result)
    if weak:
        print(weak, file=sys.stderr)
    print(json.dumps(result))
    return 0


def weak_starts_line(result: dict) -> str | None:
    """The starts scoring under half the median start (`start_returns`), for people; None if none."""
    from services.training.evaluation import weak_starts

    starts = result.get("start_returns") or []
    median, weak = weak_starts(starts)
    if not weak:
        return None
    listed = ", ".join(f"{phase:.3f} ({score:.2f})" for phase, score in weak)
    return (f"{len(weak)} of {len(starts)} starts score under half the median ({median:.2f}): phase (normalised return) "
            f"{listed}; `sfv render RUN --phase P` shows one")


def result_line(result: dict) -> str:
    """The first-frame episode beside the phase average, for people."""
    first = result["first_frame"]
    falls = int(round(result["fall_rate"] * result["episodes"]))
    how = (f"fell at {first['episode_seconds']:.2f} s of {first['clip_seconds']:.2f} s" if first["fell"]
           else f"upright to the end ({first['clip_seconds']:.2f} s)")
    return (f"from the first frame: {how}, normalised return {first['normalized_return']:.3f}; "
            f"from {result['episodes']} evenly spaced phases: normalised return {result['normalized_return']:.3f}, "
            f"{falls} of {result['episodes']} fell")
