"""What a run directory remembers of how it was asked for: `RUN/run_spec.json` holds the spec's
name and settings (or none), the settings given on top, the commit of the code and the command
line; a resumed run appends its own entry under `resumes`. The resolved config itself is the run's
`config.json` (`services/training/run_dir.py`)."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from learner.atomic_io import atomic_write_json

RECORD_FILE = "run_spec.json"
REPO = Path(__file__).resolve().parents[2]


def git_commit(repo: Path = REPO) -> str | None:
    """The checkout's commit (`+dirty` with uncommitted changes); None outside a git checkout."""
    try:
        head = subprocess.run(["git", "-C", str(repo), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=10)
        if head.returncode != 0:
            return None
        dirty = subprocess.run(["git", "-C", str(repo), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return None
    return head.stdout.strip() + ("+dirty" if dirty.stdout.strip() else "")


def _json_value(value):
    return list(value) if isinstance(value, tuple) else value


def record_run_spec(run_dir: str | Path, spec, given: dict, argv: list[str] | None = None) -> Path:
    """Write (or, on a resume, extend) RUN/run_spec.json."""
    path = Path(run_dir) / RECORD_FILE
    entry = {"spec": spec.name if spec else None, "spec_settings": {k: _json_value(v) for k, v in (spec.settings if spec else {}).items()},
             "given": {k: _json_value(v) for k, v in given.items()}, "git_commit": git_commit(),
             "command": ["sfv", *(sys.argv[1:] if argv is None else argv)]}
    if path.is_file():
        record = json.loads(path.read_text())
        record.setdefault("resumes", []).append(entry)
    else:
        record = entry
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_json(path, record)
    return path
