"""The `sfv` command line.

Every sub-command lives in its own module under `services/commands/` and exposes `HELP` (its
one-line summary) and `register(subparsers)`; the module list is discovered, so adding a
command never touches this file. Only the command being run is registered in full (its flags,
and whatever it imports to build them); the others are listed by their `HELP`, so `sfv --help`
and one command never import every command's dependencies. A command's handler returns an exit
code; `SfvError` (one line, names the file and the fault) becomes `sfv: <message>` on stderr
and exit 2.

`--verbose` (anywhere on the line) shows library output (Ray, gRPC, numeric warnings) on the
terminal; by default it goes to the run's log file (`services/console.py`).
"""
from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys

from learner.errors import SfvError, TrainingStopped
from services import commands

VERBOSE_FLAG = "--verbose"


def command_modules() -> dict[str, str]:
    """Command name (`render-motion`) -> module name (`render_motion`), sorted."""
    names = sorted(info.name for info in pkgutil.iter_modules(commands.__path__) if not info.name.startswith("_"))
    return {name.replace("_", "-"): name for name in names}


def _chosen_command(argv: list[str]) -> str | None:
    """The sub-command named on the line (the first word that is not an option)."""
    for word in argv:
        if not word.startswith("-"):
            return word
    return None


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The parser; with `argv`, only the command it names is registered in full (all of them
    without `argv`)."""
    parser = argparse.ArgumentParser(prog="sfv", description="Skills from videos: video -> reference motion -> physics controller.")
    parser.add_argument(VERBOSE_FLAG, action="store_true", help="show library output (Ray, gRPC, warnings) on the terminal too")
    sub = parser.add_subparsers(dest="command", required=True)
    chosen = _chosen_command(argv) if argv is not None else None
    for name, module_name in command_modules().items():
        module = importlib.import_module(f"services.commands.{module_name}")
        if argv is None or name == chosen:
            module.register(sub)
            sub.choices[name].add_argument(VERBOSE_FLAG, action="store_true", default=argparse.SUPPRESS,
                                           help="show library output (Ray, gRPC, warnings) on the terminal too")
        else:
            sub.add_parser(name, help=module.HELP)
    return parser


def _run(args: argparse.Namespace) -> tuple[int, str | None]:
    """The handler's exit code, and the one `sfv: ...` line to print last (after whatever native
    output a failed command shows), or None."""
    try:
        return int(args.handler(args) or 0), None
    except SfvError as exc:
        return 2, f"sfv: {exc}"
    except TrainingStopped as exc:  # a stop signal, the checkpoint written
        return exc.exit_code, f"sfv: {exc}"
    except KeyboardInterrupt:
        return 130, "sfv: interrupted"


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    from services import console
    from services.native_output import ROUTE
    from services.render.gl import defuse_unusable_backend

    # Before anything imports gRPC, Ray or MuJoCo: quiet libraries, and no GL a command does not need.
    verbose = VERBOSE_FLAG in argv
    console.configure(verbose=verbose)
    defuse_unusable_backend()
    args = build_parser(argv).parse_args(argv)
    routed = not verbose and ROUTE.start()  # native library output (fd 2) to the run's log
    code, message = 1, None
    try:
        code, message = _run(args)
        return code
    finally:
        if routed:
            ROUTE.stop(failed=code != 0)
        if message is not None:  # the error line last, below the library's own words
            print(message, file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
