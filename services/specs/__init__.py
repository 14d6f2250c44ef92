"""Named run specs: every configuration behind a reported number, frozen under a name.

A `RunSpec` names the command that runs it and the config settings it fixes (body, motion, mode,
arena, budget and the other overrides, as config paths: `samples`, `env.character`, ...);
everything else is the config dataclasses' defaults of the commit that runs it. `sfv train SPEC`
(and `sfv task SPEC`) apply the spec's settings under whatever the command line gives, so flags
stay overrides; the run directory records the spec, the resolved config and the commit
(`services/specs/record.py`). The catalogue (`catalog.py`) holds the skills table, the G1 rows,
SFV's Table 2 cells, the video pipeline's defaults and the NPMP module and tasks;
`sfv train --specs` lists them.
"""
from __future__ import annotations

from learner.errors import SfvError
from services.specs.spec import RUN_SPECS, RunSpec, register

__all__ = ["RUN_SPECS", "RunSpec", "register", "run_spec", "spec_table", "specs_for"]


def specs_for(command: str) -> dict[str, RunSpec]:
    """The registered specs a command runs, by name."""
    from services.specs import catalog  # noqa: F401  (registers the catalogue)

    return {name: spec for name, spec in RUN_SPECS.items() if spec.command == command}


def run_spec(name: str, command: str) -> RunSpec:
    """The spec `name` of `command` (SfvError in one line naming the ones there are)."""
    specs = specs_for(command)
    if name not in specs:
        raise SfvError(f"no {command} spec {name!r} (specs: {', '.join(specs)}; `sfv train --specs` lists them)")
    return specs[name]


def spec_table(command: str | None = None) -> str:
    """One line per spec: name, command, summary, report (what `--specs` prints)."""
    from services.specs import catalog  # noqa: F401

    rows = [spec for spec in RUN_SPECS.values() if command is None or spec.command == command]
    width = max(len(spec.name) for spec in rows)
    return "\n".join(f"{spec.name:<{width}}  sfv {spec.command:<8}  {spec.summary}  [{spec.report or 'no results file'}]"
                     for spec in rows)
