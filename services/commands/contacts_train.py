"""`sfv contacts-train --out DIR`: (re)train the foot-contact network on synthetic views of the
DeepMimic clips and write foot_contact.onnx / .sha256 / .json (the shipped copy lives in
services/contacts/weights)."""
from __future__ import annotations

import argparse
from pathlib import Path

from learner.errors import SfvError


HELP = "train the foot-contact estimator (ONNX) from mocap clips"  # the one line `sfv --help` lists (without importing the command)


def register(subparsers: argparse._SubParsersAction) -> None:
    from services.contacts.settings import TrainSettings

    defaults = TrainSettings()
    parser = subparsers.add_parser("contacts-train", help=HELP)
    parser.add_argument("--out", type=Path, required=True, help="directory for foot_contact.onnx, .sha256 and .json")
    parser.add_argument("--epochs", type=int, default=defaults.epochs, help="passes over the training windows")
    parser.add_argument("--cameras", type=int, default=defaults.cameras_per_clip,
                        help="random cameras per clip and mirror (the four camera kinds take turns)")
    parser.add_argument("--seed", type=int, default=defaults.seed, help="seed of the cameras, noise and training")
    parser.add_argument("--held-out", default=",".join(defaults.held_out),
                        help="comma-separated DeepMimic clips left out of training and scored on their own cameras")
    parser.add_argument("--torch-threads", type=int, default=1, help="CPU threads for torch")
    parser.set_defaults(handler=run_contacts_train)


def run_contacts_train(args: argparse.Namespace) -> int:
    import dataclasses

    import torch

    from services.contacts.settings import TrainSettings
    from services.contacts.training import save_shipped, train_contact_network

    if args.epochs < 1 or args.cameras < 1 or args.torch_threads < 1:
        raise SfvError("--epochs, --cameras and --torch-threads must be >= 1")
    from actors.motion.formats.io import DEEPMIMIC_CLIPS

    held_out = tuple(name for name in args.held_out.split(",") if name)
    unknown = [name for name in held_out if name not in DEEPMIMIC_CLIPS]
    if unknown or not held_out:
        raise SfvError(f"--held-out {args.held_out!r}: name one or more of {', '.join(DEEPMIMIC_CLIPS)}"
                       + (f" ({', '.join(unknown)} is not one)" if unknown else ""))
    torch.set_num_threads(args.torch_threads)
    settings = dataclasses.replace(TrainSettings(), epochs=args.epochs, cameras_per_clip=args.cameras, seed=args.seed,
                                   held_out=held_out)
    network, report = train_contact_network(settings)
    path = save_shipped(network, report, args.out)
    table = ", ".join(f"{k} {v:.3f}" for k, v in report["held_out_accuracy"].items())
    print(f"held-out clips: {table}; train {report['train_accuracy']:.3f} -> {path}")
    return 0
