"""The results tables of the README and docs/robots.md are checked against the JSON behind them:
every row naming a run spec shows that spec's budget and the normalised return and falls its
results file records."""
from __future__ import annotations

import json
import re

from services.specs import specs_for
from tests.conftest import REPO

# | `walk` | 2 M | .981 | 0 |  or  | `g1-walk` | 3 M | .967 | 0 / 32 |  (a row may hold two specs side by side)
ROW_CELL = re.compile(r"\| `([a-z0-9-]+)` \| ([\d.]+) M \| (\.\d{3}) \| (\d+)(?: / \d+)? ")
DOCUMENTS = ("README.md", "docs/robots.md")


def eval_figures(report: str, motion: str) -> dict:
    """The strict evaluation a results file records for `motion`: an `sfv eval` object, one under
    `result`, or a learning suite's record (`runs`, the run of that motion)."""
    data = json.loads((REPO / report).read_text())
    if "runs" in data:
        runs = data["runs"] if isinstance(data["runs"], list) else list(data["runs"].values())
        return next(run["eval"] for run in runs if run["skill"] == motion)
    return data.get("result", data)


def results_rows() -> list[tuple[str, str, str, str]]:
    return [m.groups() for doc in DOCUMENTS for line in (REPO / doc).read_text().splitlines() for m in ROW_CELL.finditer(line)]


def test_the_results_rows_match_their_specs_and_results_files():
    specs = specs_for("train")
    rows = results_rows()
    assert len(rows) >= 23  # the 15 skills and the 4 G1 rows, the G1 rows again in docs/robots.md
    for name, samples, nr, falls in rows:
        spec = specs[name]
        assert float(samples) == spec.settings["samples"] / 1e6, name
        figures = eval_figures(spec.report, spec.settings["motion"])
        assert nr == f"{figures['normalized_return']:.3f}".lstrip("0"), (name, nr, figures["normalized_return"])
        assert int(falls) == round(figures["fall_rate"] * figures["episodes"]), (name, falls, figures["fall_rate"])


def test_the_row_reader_sees_a_changed_number():
    assert ROW_CELL.findall("| `walk` | 2 M | .981 | 0 | `run` | 3 M | .906 | 0 |") == [
        ("walk", "2", ".981", "0"), ("run", "3", ".906", "0")]
    assert ROW_CELL.findall("| `g1-jump` | 4 M | .870 | 2 / 32 | [G1 report](x) |") == [("g1-jump", "4", ".870", "2")]
