"""Flags shared by `sfv pose` and `sfv reconstruct`: which person, which frames."""
from __future__ import annotations

import argparse

from learner.errors import SfvError


def add_person_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--person", type=int, default=None, metavar="ID",
                        help="follow this identity (ids as `sfv pose --people PREVIEW.png` lists them); "
                             "default: of the people seen throughout, the one who moves most (said in one line)")
    parser.add_argument("--person-at", default=None, metavar="X,Y@FRAME",
                        help="follow the person whose keypoints cover pixel X,Y in frame FRAME")
    parser.add_argument("--frames", default=None, metavar="A:B",
                        help="only video frames A..B-1 (either end may be left out: 100:, :300)")


def person_choice(args: argparse.Namespace):
    from services.pose.subject import PersonChoice, parse_person_at

    if args.person is not None and args.person_at is not None:
        raise SfvError("--person and --person-at exclude each other")
    if args.person is not None and args.person < 0:
        raise SfvError(f"--person must be >= 0, got {args.person}")
    return PersonChoice(person=args.person, at=parse_person_at(args.person_at) if args.person_at else None)


def frame_range(args: argparse.Namespace):
    from services.pose.subject import parse_frames

    return parse_frames(args.frames) if args.frames else None
