"""`sfv bench --suite scaling`: throughput against workers, synchronous and asynchronous, and the
learner/driver ceiling with synthetic workers, and more workers than cores emulated by paced ones."""
from __future__ import annotations

import json

import pytest

from services.bench.scaling_suite import steady_state
from services.cli import main


def test_steady_state_leaves_the_first_iteration_out():
    rows = [{"time": 100.0, "samples": 4096, "learner_update_s": 9.0, "policy_lag_mean": 0.0},
            {"time": 102.0, "samples": 8192, "learner_update_s": 0.5, "policy_lag_mean": 1.0},
            {"time": 104.0, "samples": 12288, "learner_update_s": 1.5, "policy_lag_mean": 0.5}]
    figures = steady_state(rows)
    assert figures["samples_per_s"] == pytest.approx(8192 / 4.0)
    assert figures["learner_utilisation"] == pytest.approx(2.0 / 4.0)
    assert figures["policy_lag"] == pytest.approx(0.75)
    with pytest.raises(ValueError):
        steady_state(rows[:2])


def test_bad_scaling_workers_is_a_one_line_error(tmp_path, capsys):
    assert main(["bench", "--suite", "scaling", "--scaling-workers", "0,2", "--out", str(tmp_path / "s.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert "--scaling-workers '0,2'" in err and "\n" not in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_quick_scaling_suite_on_the_processes_runner(tmp_path):
    out = tmp_path / "scaling.json"
    assert main(["bench", "--suite", "scaling", "--quick", "--quiet", "--repeats", "1", "--scaling-workers", "1",
                 "--scaling-runners", "processes", "--scaling-paced-workers", "3", "--scaling-paced-rate", "1000",
                 "--out", str(out)]) == 0
    suite = json.loads(out.read_text())["suites"]["scaling"]
    metrics = {k: v["median"] for k, v in suite["metrics"].items()}
    assert metrics["scaling_processes_1w_sync_policy_lag"] == 0.0
    assert 0.5 <= metrics["scaling_processes_1w_async_policy_lag"] <= 1.0  # workers sampled while the learner updated
    for loop in ("sync", "async"):
        assert 0.0 < metrics[f"scaling_processes_1w_{loop}_learner_utilisation"] <= 1.0
        assert suite["ratios"][f"scaling_processes_1w_{loop}_over_raw"]["value"] == pytest.approx(
            metrics[f"scaling_processes_1w_{loop}_samples_per_s"] / metrics["raw_steps_per_s"])
    assert "synthetic_processes_2w_async_samples_per_s" in metrics
    for loop in ("sync", "async"):  # 3 emulated workers offer 3 x 1,000 samples/s; replayed unpaced they give ~10 k
        # (a short window: the asynchronous loop's first measured batch started sampling during the update before it)
        assert 0.0 < metrics[f"paced_processes_3w_{loop}_samples_per_s"] <= 1.5 * 3 * 1000
    assert suite["settings"]["paced_workers"] == [3]
    assert (tmp_path / "scaling.png").is_file()
