"""The `sfv` command line.

Every sub-command lives in its own module under `services/commands/` and exposes
`register(subparsers)`; the module list is discovered, so adding a command never
touches this file. A command's handler returns an exit code; `SfvError` (one line,
names the file and the fault) becomes `sfv: <message>` on stderr and exit 2.
"""
from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys

from learner.errors import SfvError
from services import commands


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="sfv", description="Skills from videos: video -> reference motion -> physics controller.")
    sub = parser.add_subparsers(dest="command", required=True)
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda m: m.name):
        module = importlib.import_module(f"services.commands.{info.name}")
        if hasattr(module, "register"):
            module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.handler(args) or 0)
    except SfvError as exc:
        print(f"sfv: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("sfv: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
