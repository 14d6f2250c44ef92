"""bench/scripts/compare_runs.py: runs side by side (config differences, curves at marks, evaluations, fall causes)."""
from __future__ import annotations

import json

import pytest

from learner.errors import SfvError
from services.training.config import TrainConfig
from services.training.run_dir import CONFIG_FILE, METRICS_FILE
from tests.bench_scripts import load_bench_script


@pytest.fixture(scope="module")
def compare():
    return load_bench_script("compare_runs")


def write_run(path, lengths, evals=(), **changes):
    path.mkdir(parents=True)
    config = TrainConfig(out=str(path))
    for key, value in changes.items():
        setattr(config, key, value)
    (path / CONFIG_FILE).write_text(json.dumps(config.to_dict()))
    rows = [{"samples": 25_000 * (k + 1), "episode_length": n, "reward_mean": 0.5, "normalized_return": 0.1,
             "falls/neck": 0.5} for k, n in enumerate(lengths)]
    rows += [{"samples": s, "eval/normalized_return": v, "eval/fall_rate": 1.0} for s, v in evals]
    (path / METRICS_FILE).write_text("".join(json.dumps(r) + "\n" for r in rows))


def test_marks_differences_and_evaluations(tmp_path, compare, capsys):
    write_run(tmp_path / "a", [10, 20, 30, 40])
    write_run(tmp_path / "b", [10, 30, 50, 70], evals=[(100_000, 0.4)], init="rsi", seed=3)
    out = tmp_path / "cmp.json"
    assert compare.main([str(tmp_path / "a"), str(tmp_path / "b"), "--marks", "50k,100k", "--out", str(out),
                         "--png", str(tmp_path / "cmp.png")]) == 0
    doc = json.loads(out.read_text())
    a, b = doc["runs"]
    assert a["differs"] == {} and b["differs"] == {"init": "rsi", "seed": 3}
    assert a["at"]["100000"]["episode_length"] == 35.0 and b["at"]["50000"]["episode_length"] == 20.0  # the 50 k before each mark
    assert b["eval"] == [{"samples": 100_000, "eval/normalized_return": 0.4, "eval/fall_rate": 1.0}] and a["eval"] == []
    assert b["falls"] == {"falls/neck": 0.5}
    assert (tmp_path / "cmp.png").read_bytes()[:4] == b"\x89PNG"
    assert "b: 50k: 20 steps" in capsys.readouterr().out


def test_bad_input_is_one_line(tmp_path, compare, capsys):
    with pytest.raises(SfvError, match="'1x'"):
        compare.parse_samples("1x")
    assert compare.parse_samples("1.5M") == 1_500_000 and compare.parse_samples("250k") == 250_000
    assert compare.main([str(tmp_path), "--out", str(tmp_path / "x.json")]) == 2
    assert "not a run directory" in capsys.readouterr().err and not (tmp_path / "x.json").exists()


def test_an_earlier_comparisons_run_is_listed_and_drawn_beside_the_new_one(tmp_path, compare, capsys):
    write_run(tmp_path / "old", [10, 20], evals=[(50_000, 0.2)])
    first = tmp_path / "first.json"
    assert compare.main([str(tmp_path / "old"), "--marks", "50k", "--out", str(first)]) == 0
    write_run(tmp_path / "new", [10, 40], evals=[(50_000, 0.5)])
    out, png = tmp_path / "cmp.json", tmp_path / "cmp.png"
    assert compare.main([str(tmp_path / "new"), "--marks", "50k", "--earlier", f"{first}:old", "--out", str(out), "--png", str(png)]) == 0
    old, new = json.loads(out.read_text())["runs"]
    assert old["earlier"] == str(first) and old["eval"][0]["eval/normalized_return"] == 0.2 and "earlier" not in new
    assert new["eval"][0]["eval/normalized_return"] == 0.5 and png.read_bytes()[:4] == b"\x89PNG"
    assert compare.main([str(tmp_path / "new"), "--earlier", f"{first}:nobody", "--out", str(tmp_path / "x.json")]) == 2
    assert "no run named 'nobody'" in capsys.readouterr().err and not (tmp_path / "x.json").exists()
