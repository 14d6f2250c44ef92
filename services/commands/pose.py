"""`sfv pose VIDEO --out TRACK.npz`: per-frame BlazePose 2D + 3D landmarks of a video's subject
(everyone is tracked; `--people PREVIEW.png` shows who is who)."""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from learner.errors import SfvError
from services.commands._person_args import add_person_arguments, frame_range, person_choice


HELP = "estimate the actor's pose in every frame of a video (Ray tasks)"  # the one line `sfv --help` lists (without importing the command)


def register(subparsers: argparse._SubParsersAction) -> None:
    from services.pose import PoseConfig
    from services.pose.models import MODELS_ENV

    parser = subparsers.add_parser("pose", help=HELP)
    parser.add_argument("video", type=Path, help="input video file")
    parser.add_argument("--out", type=Path, default=None, help="output pose track of the subject (.npz)")
    parser.add_argument("--people", type=Path, default=None, metavar="PREVIEW.png",
                        help="write a contact sheet of every identity (first, middle, last appearance) and list them")
    parser.add_argument("--pose-models", metavar="DIR", default=None,
                        help="directory with pose_detection.tflite + pose_landmark_full.tflite "
                             f"(default ${MODELS_ENV} or the `sfv models fetch` cache)")
    parser.add_argument("--landmark-model", metavar="FILE", default=None,
                        help="landmark model to use instead of the directory's (.tflite or .onnx)")
    parser.add_argument("--chunk-frames", type=int, default=PoseConfig().chunk_frames,
                        help="frames per Ray task")
    parser.add_argument("--serial", action="store_true", help="run in this process instead of as Ray tasks")
    add_person_arguments(parser)
    parser.set_defaults(handler=run_pose)


def run_pose(args: argparse.Namespace) -> int:
    from services.pose.contact_sheet import write_contact_sheet
    from services.pose.pipeline import estimate_people
    from services.pose.subject import choose_subject, subject_reason, subject_track

    if args.chunk_frames < 1:
        raise SfvError(f"--chunk-frames must be >= 1, got {args.chunk_frames}")
    if args.out is None and args.people is None:
        raise SfvError("sfv pose needs --out TRACK.npz, --people PREVIEW.png or both")
    if args.out is not None and args.out.suffix != ".npz":
        raise SfvError(f"{args.out}: output must be a .npz file")
    if args.people is not None and args.people.suffix.lower() != ".png":
        raise SfvError(f"{args.people}: --people preview must be a .png file")
    choice, frames = person_choice(args), frame_range(args)
    started = time.perf_counter()
    people = estimate_people(args.video, models_dir=args.pose_models, use_ray=not args.serial,
                             chunk_frames=args.chunk_frames, landmark_model=args.landmark_model, frames=frames)
    person = choose_subject(people, choice, str(args.video))
    elapsed = time.perf_counter() - started
    if args.people is not None:
        write_contact_sheet(people, args.video, args.people)
        for s in people.people():
            print(f"  person {s.person}: frames {s.first_frame}-{s.last_frame}, seen in {s.frames_seen}, "
                  f"size {s.size_px:.0f} px, moves {s.activity:.1f} body sizes/s{'  <- subject' if s.person == person else ''}")
    print(subject_reason(people, person, choice))
    track = subject_track(people, person)
    if args.out is not None:
        track.save(args.out)
    print(f"{args.video}: {people.frame_count} frames, person in {int(track.valid.sum())} (subject {person} of "
          f"{len(people.people())} people), {track.filled_frames} filled by interpolation, "
          f"{people.frame_count / elapsed:.1f} frames/s -> {', '.join(str(p) for p in (args.out, args.people) if p)}")
    return 0
