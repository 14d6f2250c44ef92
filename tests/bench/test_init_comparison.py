"""bench/scripts/init_comparison.py: SFV's Table 2 in spirit from a learning suite's record."""
from __future__ import annotations

import json
import math

import pytest

from learner.errors import SfvError
from services.training.run_dir import METRICS_FILE
from tests.bench_scripts import load_bench_script


@pytest.fixture(scope="module")
def table():
    return load_bench_script("init_comparison")


def entry(init, seed, nr, falls, evals, status="complete"):
    return {"name": f"cartwheel_{init}_s{seed}", "skill": "deepmimic:cartwheel", "init": init, "seed": seed,
            "status": status, "run_dir": f"runs/cartwheel_{init}_s{seed}", "samples": 3_000_000, "wall_s": 1800.0,
            "config": {"samples": 3_000_000},
            "eval": {"normalized_return": nr, "fall_rate": falls / 32, "episodes": 32} if status == "complete" else {},
            "curve": {"eval": {"samples": [1_000_000, 2_000_000, 3_000_000], "eval/normalized_return": evals}}}


def write_suite(tmp_path, nrs: dict, shifts=(0.1, 0.2, 0.3), extra=()):
    runs = {}
    for init, values in nrs.items():
        for seed, nr in enumerate(values):
            runs[f"cartwheel_{init}_s{seed}"] = entry(init, seed, nr, falls=seed, evals=[nr / 4, nr / 2, nr])
    for e in extra:
        runs[e["name"]] = e
    (tmp_path / "learning.json").write_text(json.dumps({"format": "sfv-learning-1", "runs": runs}))
    for seed, shift in enumerate(shifts):
        run = tmp_path / "runs" / f"cartwheel_asi_s{seed}"
        run.mkdir(parents=True)
        rows = [{"samples": 4096, "asi/mean_shift_sigma": 0.0, "asi/std_ratio": 1.0},
                {"samples": 8192, "normalized_return": 0.1},  # an iteration without ASI keys keeps the last value
                {"samples": 12288, "asi/mean_shift_sigma": shift, "asi/std_ratio": 1.0 + shift}]
        (run / METRICS_FILE).write_text("".join(json.dumps(r) + "\n" for r in rows))


def test_order_gaps_marks_and_asi_movement(tmp_path, table, capsys):
    write_suite(tmp_path, {"fsi": [0.30, 0.32, 0.34], "rsi": [0.60, 0.50, 0.70], "asi": [0.62, 0.58, 0.66]})
    out = tmp_path / "t2.json"
    assert table.main([str(tmp_path), "--marks", "1M,2.5M", "--out", str(out)]) == 0
    skill = json.loads(out.read_text())["skills"]["deepmimic:cartwheel"]
    asi, rsi, fsi = (skill["inits"][k] for k in ("asi", "rsi", "fsi"))
    assert skill["order"]["ranked"] == ["asi", "rsi", "fsi"]
    assert asi["normalized_return_mean"] == pytest.approx(0.62) and asi["normalized_return_std"] == pytest.approx(0.04)
    # asi - rsi: +0.02 against a standard error of sqrt(.04^2/3 + .1^2/3): not separated; rsi - fsi: +0.28, separated
    first, second = skill["order"]["gaps"]
    assert first["standard_error"] == pytest.approx(math.sqrt((0.04 ** 2 + 0.1 ** 2) / 3)) and not first["separated"]
    assert second["separated"] and skill["order"]["line"] == "ASI ~ RSI > FSI"
    assert asi["eval_at_mean"] == {"1000000": pytest.approx(0.62 / 4), "2500000": pytest.approx(0.62 / 2)}
    assert asi["mean_shift_sigma"] == pytest.approx(0.2) and asi["std_ratio"] == pytest.approx(1.2)
    assert "mean_shift_sigma" not in rsi and fsi["fall_rate_mean"] == pytest.approx(1 / 32)
    text = capsys.readouterr().out
    assert "ASI ~ RSI > FSI" in text and "| asi | 3 | 0.620, 0.580, 0.660 |" in text and "0/32, 1/32, 2/32" in text


def test_an_unfinished_run_is_listed_not_averaged(tmp_path, table):
    write_suite(tmp_path, {"fsi": [0.3, 0.5], "asi": [0.4, 0.4]}, shifts=(0.1, 0.1),
                extra=[entry("fsi", 2, None, 0, [0.9, None, None], status="incomplete")])
    skill = table.compare(tmp_path, None, [1_000_000])["skills"]["deepmimic:cartwheel"]
    fsi = skill["inits"]["fsi"]
    assert fsi["seeds_complete"] == 2 and fsi["normalized_return_mean"] == pytest.approx(0.4)
    assert [r["status"] for r in fsi["seeds"]] == ["complete", "complete", "incomplete"]
    assert fsi["eval_at_mean"]["1000000"] == pytest.approx(0.1)  # the incomplete run's .9 is not in it
    assert skill["order"]["line"] == "ASI ~ FSI"  # equal means: no order shown


def test_bad_input_is_one_line_and_writes_nothing(tmp_path, table, capsys):
    out = tmp_path / "t2.json"
    assert table.main([str(tmp_path), "--out", str(out)]) == 2
    assert "no learning suite results" in capsys.readouterr().err
    (tmp_path / "learning.json").write_text("{")
    assert table.main([str(tmp_path), "--out", str(out)]) == 2
    assert "not JSON" in capsys.readouterr().err and not out.exists()
    write_suite(tmp_path, {"rsi": [0.5]}, shifts=())
    assert table.main([str(tmp_path), "--skill", "deepmimic:walk"]) == 2
    assert "has runs of deepmimic:cartwheel" in capsys.readouterr().err
    with pytest.raises(SfvError, match="'1x'"):
        table.parse_marks("1x")
    assert table.parse_marks("500k,1.5M") == [500_000, 1_500_000]
