"""Every flag of every `sfv` command says what it does in a line or two; measurements live in docs/."""
from __future__ import annotations

import argparse

from services.cli import build_parser

LONGEST_HELP = 400  # characters, the default shown included


def flag_helps(parser: argparse.ArgumentParser, prefix: str = "sfv"):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from flag_helps(sub, f"{prefix} {name}")
        elif action.help and action.help != argparse.SUPPRESS:
            yield f"{prefix} {'/'.join(action.option_strings) or action.dest}", action.help


def test_no_flag_help_is_a_measurement_log():
    helps = dict(flag_helps(build_parser()))
    assert len(helps) > 300  # every command registered in full
    long = {flag: len(text) for flag, text in helps.items() if len(text) > LONGEST_HELP}
    assert not long, long
