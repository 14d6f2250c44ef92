"""`sfv models fetch`: download the pretrained pose models into the user cache."""
from __future__ import annotations

import argparse


HELP = "manage pretrained model files"  # the one line `sfv --help` lists (without importing the command)


def register(subparsers: argparse._SubParsersAction) -> None:
    from services.pose.models import MEDIAPIPE_REQUIREMENT, MODELS_ENV, default_models_dir

    parser = subparsers.add_parser("models", help=HELP)
    actions = parser.add_subparsers(dest="models_action", required=True)
    fetch = actions.add_parser(
        "fetch",
        help=f"download BlazePose (from the PyPI wheel {MEDIAPIPE_REQUIREMENT}) and cache it, SHA-256 checked",
    )
    fetch.add_argument("--pose-models", metavar="DIR", default=None,
                       help=f"where to put the pose models (default: ${MODELS_ENV} or {default_models_dir()})")
    fetch.add_argument("--force", action="store_true", help="download again even if valid files are cached")
    fetch.set_defaults(handler=run_fetch)


def run_fetch(args: argparse.Namespace) -> int:
    from services.pose.models import fetch_models

    files = fetch_models(args.pose_models, force=args.force)
    print(f"pose detector: {files.detector}")
    print(f"pose landmarks: {files.landmark}")
    return 0
