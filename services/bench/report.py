"""The benchmark report as a Markdown table, and its atomic JSON file."""
from __future__ import annotations

from pathlib import Path

from learner.atomic_io import atomic_write_json


def _number(value: float) -> str:
    if abs(value) >= 100:
        return f"{value:,.0f}"
    if abs(value) >= 10:
        return f"{value:.1f}"
    return f"{value:.3f}"


def markdown_table(report: dict) -> str:
    lines = ["| suite | measurement | median | min | max | unit / target |", "|---|---|---:|---:|---:|---|"]
    for suite, result in report["suites"].items():
        if "skipped" in result:
            lines.append(f"| {suite} | skipped: {result['skipped'].replace('|', '/')} | | | | |")
            continue
        for name, m in result["metrics"].items():
            lines.append(f"| {suite} | {name} | {_number(m['median'])} | {_number(m['min'])} | {_number(m['max'])} | {m['unit']} |")
        for name, r in result["ratios"].items():
            per = r["per_repetition"]
            target = "ratio of medians"
            if "target" in r:
                target += f"; target >= {r['target']:g}: {'met' if r['meets_target'] else 'NOT met'}"
            lines.append(f"| {suite} | **{name}** | **{_number(r['value'])}** | {_number(per['min'])} | {_number(per['max'])} | {target} |")
    return "\n".join(lines)


def write_json_atomic(path: Path, report: dict) -> None:
    """Temp file in the same directory, then os.replace: never a half-written report."""
    atomic_write_json(path, report)
