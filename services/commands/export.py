"""`sfv export RUN`: what a user takes away from a run.

    sfv export RUN --onnx policy.onnx
        the deterministic policy with its observation normalisation baked in (run it with
        onnxruntime alone: `sfv eval --onnx`, `sfv render --onnx`)
    sfv export RUN --motion rollout.npz --bvh rollout.bvh [--episodes 1] [--seconds T]
        roll the policy out and record the simulated character's root and joint rotations at
        every control step, as an sfv motion (.npz; a robot's: a robot motion file) and/or BVH (Y up,
        centimetres by default, ZXY Euler channels; the humanoid's skeleton, actors/motion/formats/bvh.py,
        or a robot's bodies from its MJCF, the G1's pelvis and 29 links, actors/motion/formats/robot_bvh.py).
        With --episodes E > 1 each episode goes to its own file: NAME_ep01.npz, NAME_ep02.npz, ...

Prints one JSON object naming the files written.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from services.commands._rollout_args import add_rollout_args


HELP = "export a run's policy (ONNX) or its rollouts (.npz motion, BVH)"  # the one line `sfv --help` lists (without importing the command)


def register(sub) -> None:
    p = sub.add_parser("export", help=HELP,
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("run", help="run directory (its best policy, see --checkpoint)")
    p.add_argument("--checkpoint", choices=("best", "latest"), default="best",
                   help="best: best.pt, the best periodic evaluation (the newest checkpoint when the run has none); latest: the newest checkpoint")
    p.add_argument("--onnx", default=None, help="write the policy as ONNX here")
    p.add_argument("--motion", default=None, help="write the rollout as an sfv motion .npz here")
    p.add_argument("--bvh", default=None, help="write the rollout as BVH here (the humanoid's skeleton or a robot's bodies)")
    p.add_argument("--policy-onnx", default=None, help="roll out this exported ONNX policy instead of the checkpoint (no torch)")
    add_rollout_args(p)
    p.add_argument("--units", choices=("cm", "m"), default="cm", help="BVH length unit")
    p.set_defaults(handler=run)


def _episode_path(path: str, episode: int, episodes: int) -> Path:
    path = Path(path)
    return path if episodes == 1 else path.with_name(f"{path.stem}_ep{episode + 1:02d}{path.suffix}")


def _check_args(args) -> None:
    from learner.errors import SfvError

    if not (args.onnx or args.motion or args.bvh):
        raise SfvError("export: give --onnx FILE, --motion FILE.npz and/or --bvh FILE.bvh")
    if args.episodes < 1:
        raise SfvError(f"export: --episodes must be positive, got {args.episodes}")
    if args.seconds is not None and not args.seconds > 0:
        raise SfvError(f"export: --seconds must be positive, got {args.seconds}")
    if args.phase is not None and not 0.0 <= args.phase <= 1.0:
        raise SfvError(f"export: --phase must be in [0, 1], got {args.phase}")
    for flag, suffix in (("motion", ".npz"), ("bvh", ".bvh")):
        value = getattr(args, flag)
        if value and Path(value).suffix.lower() != suffix:
            raise SfvError(f"{value}: --{flag} must name a {suffix} file")
    for value in (args.onnx, args.motion, args.bvh):
        if value and not Path(value).resolve().parent.is_dir():
            raise SfvError(f"{value}: folder {Path(value).resolve().parent} does not exist")


def export_rollouts(args) -> list[dict]:
    from threadpoolctl import threadpool_limits

    from services.export.rollout import record_episode
    from services.training.policy_source import load_policy_source

    source = load_policy_source(args.run, args.policy_onnx, checkpoint=args.checkpoint)
    env = source.make_env()
    written = []
    for episode in range(args.episodes):
        name = f"{env.motion.name} rollout of {source.description} (seed {args.seed + episode})"
        with threadpool_limits(limits=1):  # batch-1 inference: BLAS threads only slow it down
            motion, progress = record_episode(source.policy, env, args.seed + episode, args.init, args.seconds, name, args.phase)
        entry = {"episode": episode + 1, "frames": motion.num_frames, "seconds": motion.duration, "fell": progress.terminated,
                 "normalized_return": progress.normalized_return}
        if args.motion:
            entry["motion"] = str(_save_rollout(motion, env, _episode_path(args.motion, episode, args.episodes)))
        if args.bvh:
            entry["bvh"] = str(_save_bvh(motion, env, _episode_path(args.bvh, episode, args.episodes), args.units))
        written.append(entry)
    return written


def _save_rollout(motion, env, path: Path) -> Path:
    """A humanoid rollout as an sfv motion, a robot's as a robot motion file (`sfv motion convert`'s format)."""
    from actors.motion.character_reference import HUMANOID

    if motion.character == HUMANOID:
        from actors.motion.formats.io import save_motion

        return save_motion(motion, path)
    from actors.motion.robot_motion import save_robot_motion

    return save_robot_motion(_robot_motion(motion, env), path)


def _save_bvh(motion, env, path: Path, units: str) -> Path:
    """A humanoid rollout on the humanoid's skeleton, a robot's on its MJCF bodies (`robot_bvh.py`)."""
    from actors.motion.character_reference import HUMANOID

    if motion.character == HUMANOID:
        from actors.motion.formats.bvh import write_bvh

        return write_bvh(motion, path, units)
    from actors.motion.formats.robot_bvh import write_robot_bvh

    return write_robot_bvh(_robot_motion(motion, env), env.humanoid, path, units)


def _robot_motion(motion, env):
    from actors.motion.robot_reference import robot_motion_of

    return robot_motion_of(motion, env.humanoid.character, source=env.motion.name)


def run(args) -> int:
    _check_args(args)
    summary: dict = {"run": args.run}
    if args.onnx:
        from services.export.onnx_run import export_run_onnx

        summary.update(export_run_onnx(args.run, args.onnx, checkpoint=args.checkpoint))
    if args.motion or args.bvh:
        summary["rollouts"] = export_rollouts(args)
    print(json.dumps(summary))
    return 0
