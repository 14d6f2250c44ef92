"""`sfv plot RUN [RUN ...] --out FILE.png`: learning curves of runs side by side.

One line per run (samples vs normalised return), coloured by its init strategy (ASI blue,
RSI orange, FSI green), smoothed with an exponential moving average over the raw curve.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path


HELP = "plot learning curves of one or more runs to a PNG"  # the one line `sfv --help` lists (without importing the command)


def register(sub) -> None:
    p = sub.add_parser("plot", help=HELP,
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("runs", nargs="+", help="run directories (each with metrics.jsonl)")
    p.add_argument("--out", required=True, help="PNG file to write (atomically)")
    p.add_argument("--smoothing", type=float, default=0.8, help="EMA weight in [0, 1); 0 draws the raw curves only")
    p.set_defaults(handler=run)


def run(args) -> int:
    from learner.errors import SfvError
    from services.training.curves import learning_curve, plot_learning_curves
    from services.training.run_dir import CONFIG_FILE, METRICS_FILE

    out = Path(args.out)
    if out.suffix.lower() != ".png":
        raise SfvError(f"{out}: the plot must be a .png file")
    if not out.resolve().parent.is_dir():
        raise SfvError(f"{out}: folder {out.resolve().parent} does not exist")
    if not 0.0 <= args.smoothing < 1.0:
        raise SfvError(f"plot: --smoothing must be in [0, 1), got {args.smoothing}")
    points = {}
    for run_dir in map(Path, args.runs):
        if not (run_dir / CONFIG_FILE).is_file():
            raise SfvError(f"{run_dir}: not a run directory (no {CONFIG_FILE})")
        points[str(run_dir)] = len(learning_curve(run_dir)[0])
    if not any(points.values()):
        raise SfvError(f"{', '.join(args.runs)}: no {METRICS_FILE} rows with a normalised return yet")
    plot_learning_curves([Path(r) for r in args.runs], out, smoothing=args.smoothing)
    print(json.dumps({"png": str(out), "points": points}))
    return 0
