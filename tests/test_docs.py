"""The README and docs/ stay true to the code: every `sfv ...` command they show names a real
command and real flags (as `sfv COMMAND --help` lists them), every `python`/`bash` script they run
exists, and every relative link points at a file in the repository."""
from __future__ import annotations

import argparse

import pytest

from services.cli import build_parser
from tests.docs_commands import REPO, relative_links, script_paths, sfv_command_lines


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    return next((a.choices for a in parser._actions if isinstance(a, argparse._SubParsersAction)), {})


def command_faults(argv: list[str]) -> list[str]:
    """What in `sfv ARGV` does not exist: the command, a sub-command, or a flag of the command it names."""
    parser = build_parser(argv)
    known = set(parser._option_string_actions)
    words = list(argv)
    while words and not words[0].startswith("-") and _subparsers(parser):
        choices = _subparsers(parser)
        if words[0] not in choices:
            return [f"no command {words[0]!r} (choose from {', '.join(choices)})"]
        parser = choices[words.pop(0)]
        known |= set(parser._option_string_actions)
    faults = [f"no flag {flag}" for flag in (w.split("=", 1)[0] for w in words if w.startswith("--")) if flag not in known]
    if argv[:1] == ["train"] and words and not words[0].startswith("-") and not words[0].isupper():
        from services.specs import specs_for

        faults += [] if words[0] in specs_for("train") else [f"no train spec {words[0]!r}"]
    return faults


@pytest.mark.parametrize("where, argv", sfv_command_lines(), ids=lambda v: v if isinstance(v, str) else "")
def test_every_sfv_command_in_the_docs_exists_with_its_flags(where, argv):
    faults = command_faults(argv)
    assert not faults, f"{where}: sfv {' '.join(argv)}: {'; '.join(faults)}"


def test_every_script_the_docs_run_exists():
    missing = [f"{where}: {path}" for where, path in script_paths() if not (REPO / path).is_file()]
    assert not missing, missing


def test_every_relative_link_in_the_docs_exists():
    missing = [f"{where}: {path.relative_to(REPO) if path.is_relative_to(REPO) else path}" for where, path in relative_links()
               if not path.exists()]
    assert not missing, missing


def test_the_checker_finds_a_missing_command_and_a_missing_flag():
    assert command_faults(["trian"]) and command_faults(["train", "--no-such-flag", "1"])
    assert command_faults(["motion", "chek", "x"]) and not command_faults(["motion", "check", "clip.npz"])
    assert not command_faults(["train", "--motion", "deepmimic:walk", "--workers", "2"])
    assert not command_faults(["train", "cartwheel", "--out", "runs/cw"]) and command_faults(["train", "cartweel", "--out", "x"])
