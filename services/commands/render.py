"""`sfv render RUN --out FILE.mp4`: film the trained policy beside a ghost of its reference.

    sfv render RUN --out walk.mp4 [--episodes E] [--seconds T] [--push N] [--width W --height H]
    sfv render [RUN] --onnx policy.onnx [--motion deepmimic:walk] --out walk.mp4   (no torch)

The policy acts deterministically (its mean), from the run's newest checkpoint or from an
exported ONNX file. Prints one JSON object (frames, per-episode return, ms per frame).
"""
from __future__ import annotations

import argparse
import json

from services.commands._rollout_args import add_rollout_args
from services.commands._terrain_args import add_terrain_args, terrain_change


HELP = "render a trained policy beside its reference motion to an MP4"  # the one line `sfv --help` lists (without importing the command)


def register(sub) -> None:
    p = sub.add_parser("render", help=HELP,
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("run", nargs="?", default=None, help="run directory (its best policy, see --checkpoint); optional with --onnx")
    p.add_argument("--out", required=True, help="MP4 file to write (atomically)")
    p.add_argument("--onnx", default=None, help="film an exported ONNX policy instead of the checkpoint (no torch)")
    p.add_argument("--checkpoint", choices=("best", "latest"), default="best",
                   help="best: best.pt, the best periodic evaluation (the newest checkpoint when the run has none); latest: the newest checkpoint")
    p.add_argument("--motion", default=None, help="reference motion (default: the run's); required for --onnx without a run")
    add_rollout_args(p)
    add_terrain_args(p)
    p.add_argument("--push", type=int, default=0, metavar="N", help="random horizontal pushes on the root per episode")
    p.add_argument("--push-impulse", type=float, default=40.0, help="impulse of one push (N s)")
    p.add_argument("--push-duration", type=float, default=0.1, help="seconds a push acts (whole control steps)")
    p.add_argument("--width", type=int, default=640, help="frame width (even)")
    p.add_argument("--height", type=int, default=480, help="frame height (even)")
    p.add_argument("--no-ghost", action="store_true", help="leave out the reference ghost")
    p.add_argument("--ghost-offset", type=float, default=1.0, help="metres between the ghost and the reference pose, along +y")
    p.add_argument("--shadows", action="store_true", help="cast shadows (slow in software OpenGL)")
    p.add_argument("--antialias", action="store_true", help="4x multisampling (smoother edges, ~2.5x slower in software OpenGL)")
    p.set_defaults(handler=run)


def build_config(args):
    from services.render.movie import RenderConfig
    from actors.envs.pushes import PushConfig

    return RenderConfig(
        width=args.width, height=args.height, episodes=args.episodes, seconds=args.seconds, init=args.init, phase=args.phase,
        seed=args.seed, ghost=not args.no_ghost, ghost_offset=(0.0, args.ghost_offset, 0.0), shadows=args.shadows, antialias=args.antialias,
        pushes=PushConfig(count=args.push, impulse=args.push_impulse, duration_s=args.push_duration),
    )


def run(args) -> int:
    import dataclasses

    from services.render.gl import select_backend

    select_backend()  # the GL backend the machine has, before mujoco loads; none is one line
    from services.render.movie import render_policy
    from services.render.video_writer import check_video_path
    from services.training.policy_source import load_policy_source

    config = build_config(args)
    config.validate()  # before the (slow) policy and env load
    check_video_path(args.out)
    source = load_policy_source(args.run, args.onnx, args.motion, args.checkpoint)
    change = terrain_change(args, "render")
    if change is not None:
        source = dataclasses.replace(source, env_config=change(source.env_config))
    env = source.make_env()
    legend = " (blue: reference)" if config.ghost else ""
    config = dataclasses.replace(config, label=f"{source.description} on {env.motion.name}{legend}")
    summary = render_policy(source.policy, env, args.out, config)
    summary.update(motion=env.motion.name, policy=source.description)
    print(json.dumps(summary))
    return 0
