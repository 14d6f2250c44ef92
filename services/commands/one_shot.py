"""`sfv one-shot MODULE --experts DIR`: one-shot imitation of each clip with the motor module,
relative to its expert (004 Fig. A.1); JSON (+ PNG) into --out.

    sfv one-shot MODULE --experts EXPERTS_DIR [--clips walk kick ...] [--episodes 16]
                 [--out bench/results/npmp/one_shot.json]

Default clips: those the module was trained on and those held out (its config.json).
`services/motor/one_shot.py` says how the encoder is run in closed loop and what is measured.
"""
from __future__ import annotations


def register(sub) -> None:
    import argparse

    p = sub.add_parser("one-shot", help="one-shot imitation with a motor module, relative to each clip's expert",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("module", help="motor module directory (sfv distill --out)")
    p.add_argument("--experts", required=True, help="directory of expert run directories, one per clip")
    p.add_argument("--clips", nargs="+", default=None, help="clips to imitate (default: the module's trained and held-out clips)")
    p.add_argument("--episodes", type=int, default=16, help="evaluation episodes per clip and controller (default 16)")
    p.add_argument("--out", default="bench/results/npmp/one_shot.json", help="result JSON (a PNG is written beside it)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(handler=run)


def run(args) -> int:
    import json
    from pathlib import Path

    from learner.errors import SfvError
    from services.motor.one_shot import one_shot_benchmark
    from services.motor.recorder import expert_clips

    if args.episodes < 1:
        raise SfvError("one-shot: --episodes must be >= 1")
    clips = args.clips
    if clips is None:
        try:
            record = json.loads((Path(args.module) / "config.json").read_text())
        except (OSError, ValueError) as exc:
            raise SfvError(f"{args.module}: not a motor module directory ({exc})") from None
        clips = list(record.get("clips", [])) + list(record.get("held_out", []))
    result = one_shot_benchmark(Path(args.module), Path(args.experts), expert_clips(Path(args.experts), clips), args.episodes, Path(args.out), not args.quiet)
    for clip, figures in result["clips"].items():
        print(f"{clip:12s} {'held out' if figures['held_out'] else 'trained':8s} expert NR {figures['expert']['normalized_return']:.3f}  "
              f"one-shot NR {figures['one_shot']['normalized_return']:.3f}  relative {figures['relative_return']:.2f}  "
              f"survival {figures['relative_survival']:.2f}")
    return 0
