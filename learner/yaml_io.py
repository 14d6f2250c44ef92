"""Reading a YAML file (scene files, rig maps, `sfv train --config`) with the one-line errors
sfv gives: the file and what it was meant to be, then why it could not be read or parsed.

It sits on the floor because actors (scene files, rig maps) and services (config files) both
read YAML; PyYAML is imported when a file is read."""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from learner.errors import SfvError


def read_yaml(path: str | os.PathLike, what: str, error: type[Exception] = SfvError) -> Any:
    """The document in `path` (YAML, so JSON too); `error` naming the file and `what` (e.g.
    "scene file") when it cannot be read or is not valid YAML."""
    import yaml

    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = getattr(exc, "strerror", None) or type(exc).__name__
        raise error(f"{path}: cannot read {what} ({reason})") from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise error(f"{path}: not valid YAML ({str(exc).splitlines()[0]})") from None
