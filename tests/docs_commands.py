"""The command lines and links the README and docs/ show a reader, read out of the Markdown."""
from __future__ import annotations

import re
import shlex
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
FENCE = re.compile(r"^```")
INLINE_CODE = re.compile(r"`([^`]+)`")
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
OPTIONAL = re.compile(r"\[[^\[\]]*\]")  # `[--flag VALUE]` in a usage line
SEPARATORS = {"&&", "||", ";", "|"}


def documents() -> list[Path]:
    """README.md, the docs/ pages and the benchmark pages."""
    return [REPO / "README.md", *sorted((REPO / "docs").glob("*.md")), REPO / "bench" / "README.md",
            *sorted((REPO / "bench" / "reports").glob("*.md"))]


def _code_lines(text: str) -> list[tuple[int, str]]:
    """(line number, text) of every line in a fenced block (continuations joined) and every inline code span."""
    lines, in_block, pending = [], False, ""
    for number, line in enumerate(text.splitlines(), 1):
        if FENCE.match(line.strip()):
            in_block, pending = not in_block, ""
            continue
        if in_block:
            joined = pending + line.strip()
            if joined.endswith("\\"):
                pending = joined[:-1] + " "
                continue
            lines.append((number, joined))
            pending = ""
        else:
            lines.extend((number, span) for span in INLINE_CODE.findall(line))
    return lines


def _commands(line: str) -> list[list[str]]:
    """The simple commands on a shell line, comments and optional `[...]` groups dropped."""
    line = OPTIONAL.sub(" ", line.split(" #", 1)[0]).replace("...", " ")
    try:
        words = shlex.split(line, comments=True)
    except ValueError:
        return []
    commands, current = [], []
    for word in words:
        if word in SEPARATORS:
            commands.append(current)
            current = []
        else:
            current.append(word)
    commands.append(current)
    return [c for c in commands if c]


def sfv_command_lines() -> list[tuple[str, list[str]]]:
    """('FILE:LINE', argv after `sfv`) for every `sfv ...` command the documents show."""
    found = []
    for doc in documents():
        for number, line in _code_lines(doc.read_text()):
            for words in _commands(line):
                while words and "=" in words[0] and not words[0].startswith("-"):
                    words = words[1:]  # VAR=value prefixes
                if words and Path(words[0]).name == "sfv" and len(words) > 1:
                    found.append((f"{doc.relative_to(REPO)}:{number}", words[1:]))
    return found


def script_paths() -> list[tuple[str, str]]:
    """('FILE:LINE', path) for every `python PATH.py` or `bash PATH.sh` command the documents show."""
    found = []
    for doc in documents():
        for number, line in _code_lines(doc.read_text()):
            for words in _commands(line):
                if len(words) > 1 and Path(words[0]).name in {"python", "python3", "bash"} and words[1].endswith((".py", ".sh")):
                    found.append((f"{doc.relative_to(REPO)}:{number}", words[1]))
    return found


def relative_links() -> list[tuple[str, Path]]:
    """('FILE:LINE', resolved path) for every link to a file in the repository."""
    found = []
    for doc in documents():
        for number, line in enumerate(doc.read_text().splitlines(), 1):
            for target in LINK.findall(line):
                if re.match(r"^[a-z]+:", target) or target.startswith("#"):
                    continue
                found.append((f"{doc.relative_to(REPO)}:{number}", (doc.parent / target.split("#", 1)[0]).resolve()))
    return found
