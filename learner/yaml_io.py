"""Reading a YAML file (scene files, rig maps, `sfv train --config`) with the one-line errors
sfv gives: the file and what it was meant to be, then why it could not be read or parsed.

It sits on the floor because actors (scene files, rig maps) and services (config files) both
read YAML; PyYAML is imported when a file is read.

PyYAML follows YAML 1.1, where a float needs a dot: `5e-05` (how Python and JSON write 0.00005, so
a run's own config.json given back as `--config`) would be read as a string. The loader here adds
YAML 1.2's float syntax, so `5e-05` and `1e6` are numbers."""
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
        return yaml.load(text, Loader=_loader())
    except yaml.YAMLError as exc:
        raise error(f"{path}: not valid YAML ({str(exc).splitlines()[0]})") from None


_LOADER = None
# YAML 1.2's floats (the exponent needs no dot), plus 1.1's inf and nan spellings.
_FLOAT = r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
|[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
|\.[0-9_]+(?:[eE][-+]?[0-9]+)?
|[-+]?\.(?:inf|Inf|INF)
|\.(?:nan|NaN|NAN))$"""


def _loader():
    """yaml.SafeLoader with YAML 1.2's float syntax (made once, when the first file is read)."""
    global _LOADER
    if _LOADER is None:
        import re

        import yaml

        class Loader(yaml.SafeLoader):
            pass

        Loader.yaml_implicit_resolvers = {key: list(value) for key, value in yaml.SafeLoader.yaml_implicit_resolvers.items()}
        Loader.add_implicit_resolver("tag:yaml.org,2002:float", re.compile(_FLOAT, re.X), list("-+0123456789."))
        _LOADER = Loader
    return _LOADER
