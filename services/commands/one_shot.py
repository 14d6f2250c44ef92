"""`sfv one-shot MODULE --experts DIR`: one-shot imitation of each clip with the motor module,
relative to its expert (004 Fig. A.1); JSON (+ PNG) into --out.

    sfv one-shot MODULE --experts EXPERTS_DIR [--clips walk kick ...] [--episodes 16]
                 [--out bench/results/npmp/one_shot.json]

Default clips: those the module was trained on and those held out (its config.json).
`services/motor/one_shot.py` says how the encoder is run in closed loop and what is measured.
"""
from __future__ import annotations


HELP = "one-shot imitation with a motor module, relative to each clip's expert"  # the one line `sfv --help` lists (without importing the command)


def register(sub) -> None:
    import argparse

    p = sub.add_parser("one-shot", help=HELP,
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("module", help="motor module directory (sfv distill --out)")
    p.add_argument("--experts", required=True, help="directory of expert run directories, one per clip")
    p.add_argument("--clips", nargs="+", default=None, help="clips to imitate (default: the module's trained and held-out clips)")
    p.add_argument("--episodes", type=int, default=16, help="evaluation episodes per clip and controller (default 16)")
    p.add_argument("--out", default="bench/results/npmp/one_shot.json", help="result JSON (a PNG is written beside it)")
    p.add_argument("--render-dir", default=None, help="also film one episode of each clip's one-shot imitation into DIR/<clip>.mp4 (from the clip's start)")
    p.add_argument("--seconds", type=float, default=None, help="cap on each filmed episode (default: the clip's horizon)")
    p.add_argument("--no-eval", action="store_true", help="only film (with --render-dir); no evaluation")
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
    clips = expert_clips(Path(args.experts), clips)
    if args.render_dir is not None:
        from services.motor.one_shot import render_one_shot

        for clip in clips:
            Path(args.render_dir).mkdir(parents=True, exist_ok=True)
            film = render_one_shot(Path(args.module), Path(args.experts), clip, Path(args.render_dir) / f"{clip}.mp4", args.seconds)
            print(json.dumps({"clip": clip, "video": film["video"], "episodes": film["episodes"]}))
    elif args.no_eval:
        raise SfvError("one-shot: --no-eval needs --render-dir")
    if args.no_eval:
        return 0
    result = one_shot_benchmark(Path(args.module), Path(args.experts), clips, args.episodes, Path(args.out), not args.quiet)
    for clip, figures in result["clips"].items():
        print(f"{clip:12s} {'held out' if figures['held_out'] else 'trained':8s} expert NR {figures['expert']['normalized_return']:.3f}  "
              f"one-shot NR {figures['one_shot']['normalized_return']:.3f}  relative {figures['relative_return']:.2f}  "
              f"survival {figures['relative_survival']:.2f}")
    return 0
