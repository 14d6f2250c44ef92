"""`sfv complete IMAGE --library RUN [RUN ...] --out FILE.mp4`: motion completion (SFV section 8).

    sfv complete jump.png --library runs/walk runs/run --out jump.mp4 [--seconds 3] [--pose-models DIR]

The actor's pose in the still image is estimated (BlazePose) and fitted to the humanoid;
the closest frame of all the runs' reference motions picks the policy, which is simulated
from that pose with the frame's velocities until --seconds pass or the character falls.
The video shows the image with its keypoints beside the simulated character. Prints one
JSON object: the chosen run, motion, frame, phase and pose distance (radians), every run's
best match, and the simulated length.
"""
from __future__ import annotations

import argparse
import json


HELP = "predict an actor's motion from one still image with a library of trained runs"  # the one line `sfv --help` lists (without importing the command)


def register(sub) -> None:
    from services.completion.config import CompletionConfig
    from services.pose.models import MODELS_ENV

    defaults = CompletionConfig()
    p = sub.add_parser("complete", help=HELP,
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("image", help="still image of one actor (PNG, JPEG, ...)")
    p.add_argument("--library", nargs="+", required=True, metavar="RUN", help="run directories of trained skills")
    p.add_argument("--out", required=True, help="MP4 file to write (atomically)")
    p.add_argument("--seconds", type=float, default=defaults.seconds, help="seconds of motion to predict")
    p.add_argument("--pose-models", metavar="DIR", default=None,
                   help=f"directory with the BlazePose models (default ${MODELS_ENV} or the `sfv models fetch` cache)")
    p.add_argument("--height", type=int, default=defaults.height, help="video height in pixels (even)")
    p.add_argument("--width", type=int, default=defaults.sim_width, help="width of the simulation panel in pixels (even)")
    p.set_defaults(handler=run)


def run(args) -> int:
    from services.completion.pipeline import complete_motion

    config = CompletionConfig(seconds=args.seconds, height=args.height, sim_width=args.width)
    summary = complete_motion(args.image, args.library, args.out, config, models_dir=args.pose_models)
    print(json.dumps(summary))
    return 0
