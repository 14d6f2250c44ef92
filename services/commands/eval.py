"""`sfv eval RUN`: one JSON object with the policy's normalised return, length, fall rate."""
from __future__ import annotations

import json


def register(sub) -> None:
    p = sub.add_parser("eval", help="evaluate a trained policy (prints one JSON object)")
    p.add_argument("run", nargs="?", default=None, help="run directory (newest checkpoint); optional with --onnx")
    p.add_argument("--episodes", type=int, default=10, help="episodes to average over")
    p.add_argument("--init", choices=("rsi", "fsi"), default="rsi", help="where episodes start on the reference")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--onnx", default=None, help="evaluate an exported ONNX policy instead of the checkpoint (no torch)")
    p.add_argument("--motion", default=None, help="motion for an ONNX policy without a run directory")
    p.set_defaults(handler=run)


def run(args) -> int:
    from actors.errors import SfvError
    from services.evaluate import evaluate_run

    if args.run is None and args.onnx is None:
        raise SfvError("eval: give a run directory or --onnx FILE")
    if args.episodes <= 0:
        raise SfvError(f"eval: --episodes must be positive, got {args.episodes}")
    print(json.dumps(evaluate_run(args.run, args.episodes, args.seed, args.init, args.onnx, args.motion)))
    return 0
