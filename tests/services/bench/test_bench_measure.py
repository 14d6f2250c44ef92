"""Interleaving, summaries, ratios and the Markdown table of `services.bench` (no timing)."""
from __future__ import annotations

import json

import pytest

from services.bench.measure import Summary, interleaved, rate_for, ratio
from services.bench.report import markdown_table, write_json_atomic
from services.bench.result import SuiteResult
from services.bench.runner import parse_suites


def test_interleaved_rotates_the_order_and_discards_warmup():
    calls = []
    values = iter(range(100))

    def variant(name):
        def run():
            calls.append(name)
            return float(next(values))
        return run

    runs = interleaved({"a": variant("a"), "b": variant("b"), "c": variant("c")}, repeats=4, warmup=1)
    assert calls[:3] == ["a", "b", "c"]  # warm-up
    assert calls[3:] == ["a", "b", "c", "b", "c", "a", "c", "a", "b", "a", "b", "c"]
    assert runs == {"a": [3.0, 8.0, 10.0, 12.0], "b": [4.0, 6.0, 11.0, 13.0], "c": [5.0, 7.0, 9.0, 14.0]}


def test_interleaved_rejects_zero_repeats():
    with pytest.raises(ValueError, match="repeats"):
        interleaved({"a": lambda: 1.0}, repeats=0)


def test_summary_and_ratio_of_medians():
    metrics = {"fast": Summary((10.0, 30.0, 20.0), "x/s"), "slow": Summary((5.0, 4.0, 8.0), "x/s")}
    assert (metrics["fast"].min, metrics["fast"].median, metrics["fast"].max) == (10.0, 20.0, 30.0)
    r = ratio(metrics, "fast", "slow", target=3.0)
    assert r.value == 20.0 / 5.0
    assert r.per_repetition == (2.0, 7.5, 2.5)
    d = r.to_dict()
    assert d["meets_target"] is True and d["per_repetition"]["median"] == 2.5
    assert ratio(metrics, "fast", "slow", scale=2.0).value == 20.0 / 10.0


def test_variants_may_return_several_named_values():
    values = iter(range(100))
    runs = interleaved({"a": lambda: {"a_wall": float(next(values)), "a_cpu": -1.0}, "b": lambda: float(next(values))},
                       repeats=2, warmup=1)
    assert runs == {"a_wall": [2.0, 5.0], "a_cpu": [-1.0, -1.0], "b": [3.0, 4.0]}


def test_rate_for_counts_units_over_at_least_the_asked_time():
    chunks = []

    def chunk():
        chunks.append(1)
        return 7

    rates = rate_for(0.02, chunk)
    assert rates.wall > 0 and rates.cpu > 0 and len(chunks) >= 1
    assert rates.wall <= 7 * len(chunks) / 0.02 + 1e-9  # units / elapsed with elapsed >= 0.02 s
    assert rates.named("x") == {"x_per_s": rates.wall, "x_per_cpu_s": rates.cpu}


@pytest.mark.parametrize("text, expected", [
    ("env", ("env",)), ("learner,env", ("env", "learner")), ("all", ("env", "worker", "learner", "system", "peer", "pose")),
])
def test_parse_suites(text, expected):
    assert parse_suites(text) == expected


@pytest.mark.parametrize("text", ["envs", "", "env,nope"])
def test_parse_suites_rejects_unknown(text):
    with pytest.raises(ValueError, match="choose from env, worker"):
        parse_suites(text)


def test_markdown_table_and_atomic_json(tmp_path):
    metrics = {"a_per_s": Summary((1.0, 2.0, 3.0), "x/s"), "b_per_s": Summary((2.0, 2.0, 2.0), "x/s")}
    ok = SuiteResult("env", metrics, ratios={"a_over_b": ratio(metrics, "a_per_s", "b_per_s", target=1.5)})
    report = {"suites": {"env": ok.to_dict(), "peer": SuiteResult.skip("peer", "no pybullet_envs | here").to_dict()}}
    table = markdown_table(report)
    assert "| env | **a_over_b** | **1.000** | 0.500 | 1.500 | ratio of medians; target >= 1.5: NOT met |" in table
    assert "| peer | skipped: no pybullet_envs / here |" in table
    out = tmp_path / "r.json"
    write_json_atomic(out, report)
    assert json.loads(out.read_text()) == json.loads(json.dumps(report))
    assert [p.name for p in tmp_path.iterdir()] == ["r.json"]
