"""bench/scripts/physics_rate.py: one policy, strict evaluations at several physics rates."""
from __future__ import annotations

import json

import pytest

from learner.errors import SfvError
from tests.bench_scripts import load_bench_script
from tests.services.export.test_export_onnx import make_tiny_run


@pytest.fixture(scope="module")
def physics_rate():
    return load_bench_script("physics_rate")


def test_each_rate_is_evaluated_and_written(tmp_path, physics_rate, capsys):
    make_tiny_run(tmp_path / "run")
    out = tmp_path / "rates.json"
    assert physics_rate.main([str(tmp_path / "run"), "--hz", "150,600", "--episodes", "2", "--out", str(out)]) == 0
    rows = json.loads(out.read_text())["rates"]
    assert [r["physics_hz"] for r in rows] == [150.0, 600.0] and all(r["trained_hz"] == 300.0 for r in rows)
    assert rows[0]["episode_seconds"] != rows[1]["episode_seconds"] or rows[0]["normalized_return"] != rows[1]["normalized_return"]
    assert "150 Hz: NR" in capsys.readouterr().out


def test_a_rate_off_the_control_grid_is_one_line(tmp_path, physics_rate, capsys):
    make_tiny_run(tmp_path / "run")
    with pytest.raises(SfvError, match="--hz 100"):
        physics_rate.evaluate_at_rates(str(tmp_path / "run"), [100.0], 1)
    assert physics_rate.main([str(tmp_path / "run"), "--hz", "150,x"]) == 2
    assert "--hz must be numbers" in capsys.readouterr().err
