"""`sfv models fetch`: download the pretrained pose models (or, with `--robot g1`, a robot's
model files) into the user cache, SHA-256 checked."""
from __future__ import annotations

import argparse


HELP = "manage pretrained model files"  # the one line `sfv --help` lists (without importing the command)


def register(subparsers: argparse._SubParsersAction) -> None:
    from actors.character.g1_model import MODEL_ENV as ROBOT_ENV, default_model_dir as default_robot_dir
    from actors.character.g1_spec import MJLAB_REQUIREMENT
    from services.pose.models import MEDIAPIPE_REQUIREMENT, MODELS_ENV, default_models_dir

    parser = subparsers.add_parser("models", help=HELP)
    actions = parser.add_subparsers(dest="models_action", required=True)
    fetch = actions.add_parser(
        "fetch",
        help=f"download BlazePose (from the PyPI wheel {MEDIAPIPE_REQUIREMENT}) and cache it, SHA-256 checked",
    )
    fetch.add_argument("--pose-models", metavar="DIR", default=None,
                       help=f"where to put the pose models (default: ${MODELS_ENV} or {default_models_dir()})")
    fetch.add_argument("--robot", choices=("g1",), default=None,
                       help=f"fetch a robot's model instead: g1 = Unitree G1 MJCF + meshes from {MJLAB_REQUIREMENT}")
    fetch.add_argument("--robot-dir", metavar="DIR", default=None,
                       help=f"where to put the robot's files (default: ${ROBOT_ENV} or {default_robot_dir()})")
    fetch.add_argument("--force", action="store_true", help="download again even if valid files are cached")
    fetch.set_defaults(handler=run_fetch)


def run_fetch(args: argparse.Namespace) -> int:
    if args.robot is not None:
        from services.robots.fetch import fetch_robot

        if args.pose_models is not None:
            from learner.errors import SfvError

            raise SfvError("--pose-models applies to the pose models, not to --robot (use --robot-dir)")
        print(f"{args.robot} model: {fetch_robot(args.robot, args.robot_dir, force=args.force)}")
        return 0
    if args.robot_dir is not None:
        from learner.errors import SfvError

        raise SfvError("--robot-dir needs --robot")
    from services.pose.models import fetch_models

    files = fetch_models(args.pose_models, force=args.force)
    print(f"pose detector: {files.detector}")
    print(f"pose landmarks: {files.landmark}")
    return 0
