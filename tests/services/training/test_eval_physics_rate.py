"""`sfv eval --physics-hz`: the run's policy simulated at another physics rate."""
from __future__ import annotations

import json

import pytest

from services.cli import main
from tests.services.training.test_eval_first_frame import _hold, _run


def _eval(run, capsys, *extra) -> dict:
    assert main(["eval", str(run), "--episodes", "2", *extra]) == 0
    return json.loads(capsys.readouterr().out)


def test_the_rate_given_is_the_rate_simulated(tmp_path, capsys):
    run = _run(tmp_path, loop=True, edit=_hold)
    at_run_rate = _eval(run, capsys)
    at_600 = _eval(run, capsys, "--physics-hz", "600")
    at_30 = _eval(run, capsys, "--physics-hz", "30")
    assert at_run_rate["physics_hz"] == 300.0 and at_600["physics_hz"] == 600.0
    # Holding the reference by PD converges with the rate (300 and 600 Hz agree); with one
    # physics step per control step the hands miss their targets by ~12 cm (measured) instead of ~1.
    assert at_600["end_effector_error_m"] == pytest.approx(at_run_rate["end_effector_error_m"], rel=0.2)
    assert at_30["end_effector_error_m"] > 4 * at_run_rate["end_effector_error_m"], at_30
    assert at_30["normalized_return"] < at_run_rate["normalized_return"] - 0.05


def test_a_rate_that_is_not_a_multiple_of_the_control_rate_is_refused(tmp_path, capsys):
    run = _run(tmp_path, loop=True, edit=_hold)
    assert main(["eval", str(run), "--episodes", "1", "--physics-hz", "100"]) != 0
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.strip() == "sfv: --physics-hz 100 must be a whole multiple of the run's control rate 30 Hz"
