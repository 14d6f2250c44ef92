"""A run spec: a command and the config settings it fixes, frozen, in one registry."""
from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Mapping

from learner.registry import Registry


@dataclass(frozen=True)
class RunSpec:
    name: str
    command: str  # the sfv command that runs it: train, task, distill, pipeline
    summary: str  # one line: what it is and what it measured
    settings: Mapping[str, Any]  # config path -> value, over the command's defaults
    report: str | None  # the file under bench/ whose numbers it backs (None: not checked in yet)

    def __post_init__(self):
        object.__setattr__(self, "settings", MappingProxyType(dict(self.settings)))


RUN_SPECS = Registry("run spec")


def register(spec: RunSpec) -> RunSpec:
    RUN_SPECS.register(spec.name, spec)
    return spec
