"""services.bench.run_history: training time from a run's metrics, and the settings check for runs moved into a suite."""
from __future__ import annotations

import pytest

from services.bench.run_history import BREAK_S, active_seconds, setting_differences, training_seconds


def test_training_time_sums_iterations_and_leaves_out_a_stop_and_resume():
    rows = [{"samples": 4096 * (i + 1), "time": 1000.0 + 2.0 * i, "samples_per_s": 2048.0} for i in range(5)]  # 2 s each
    resumed_at = rows[-1]["time"] + 3600.0  # an hour stopped, then one iteration at 1,024 samples/s
    rows.append({"samples": 4096 * 6, "time": resumed_at, "samples_per_s": 1024.0})
    rows.append({"samples": 4096 * 7, "time": resumed_at + 3.0, "samples_per_s": 1365.0})
    seconds = active_seconds(rows)
    assert seconds[0] == pytest.approx(2.0)  # the first iteration at its own rate
    assert seconds[4] == pytest.approx(2.0 + 4 * 2.0)
    assert seconds[5] == pytest.approx(10.0 + 4.0)  # not the hour: the resumed iteration at its rate
    assert training_seconds(rows) == pytest.approx(17.0)
    short_pause = [{"samples": 4096, "time": 0.0, "samples_per_s": 4096.0}, {"samples": 8192, "time": BREAK_S - 1.0}]
    assert training_seconds(short_pause) == pytest.approx(BREAK_S)  # an evaluation or a quick restart counts


def test_rows_without_time_stamps_give_no_time():
    assert active_seconds([{"samples": 4096}]) == [None]
    assert training_seconds([{"samples": 4096}]) is None


def test_setting_differences_ignore_how_a_run_was_operated():
    wanted = {"motion": "deepmimic:jump", "out": "a", "runner": "processes", "samples": 4_000_000, "eval_every": 400_000,
              "ppo": {"policy_hidden": (1024, 512), "reward_max": 1.0}, "env": {"sfv": {"tracking_termination_m": 1.0}}}
    saved = {**wanted, "out": "b", "runner": "ray", "samples": 2_000_000, "eval_every": 500_000, "job_id": "x",
             "ppo": {"policy_hidden": [1024, 512], "reward_max": 1.0000000000000002}}
    assert setting_differences(saved, wanted) == []
    saved["env"] = {"sfv": {"tracking_termination_m": 0.0}}
    saved["asi_phase_spread"] = 1.0
    assert setting_differences(saved, wanted) == ["asi_phase_spread", "env.sfv.tracking_termination_m"]
