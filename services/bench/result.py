"""What one suite hands back: its summaries, its ratios, its settings, or why it skipped."""
from __future__ import annotations

from dataclasses import dataclass, field

from services.bench.measure import Ratio, Summary


@dataclass
class SuiteResult:
    name: str
    metrics: dict[str, Summary] = field(default_factory=dict)
    ratios: dict[str, Ratio] = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    skipped: str | None = None
    seconds: float = 0.0

    @classmethod
    def skip(cls, name: str, reason: str, **settings) -> SuiteResult:
        return cls(name, settings=dict(settings), skipped=reason)

    def to_dict(self) -> dict:
        out: dict = {"settings": self.settings, "notes": self.notes, "seconds": self.seconds}
        if self.skipped is not None:
            out["skipped"] = self.skipped
            return out
        out["metrics"] = {k: v.to_dict() for k, v in self.metrics.items()}
        out["ratios"] = {k: v.to_dict() for k, v in self.ratios.items()}
        return out
