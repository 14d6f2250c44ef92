"""A registry of named things of one kind (env modes, characters): each name registered once,
an unknown name a ValueError naming the registered ones. A dict, so lookups stay plain."""
from __future__ import annotations


class Registry(dict):
    def __init__(self, kind: str):
        super().__init__()
        self.kind = kind  # how the error names a thing: "env mode", "character"

    def register(self, name: str, item) -> None:
        if name in self:
            raise ValueError(f"{self.kind} {name!r} is already registered")
        self[name] = item

    def named(self, name: str):
        try:
            return self[name]
        except KeyError:
            raise ValueError(f"{self.kind} must be one of {', '.join(self)}, got {name!r}") from None
