"""bench/scripts/pd_tracking.py: pure PD tracking per clip, lead and start spread."""
from __future__ import annotations

import json

import pytest

from tests.bench_scripts import load_bench_script


@pytest.fixture(scope="module")
def pd_tracking():
    return load_bench_script("pd_tracking")


def test_rows_per_setting_and_the_lead_tracks_closer(tmp_path, pd_tracking):
    out = tmp_path / "pd.json"
    assert pd_tracking.main(["--clips", "walk", "--leads", "0,2", "--asi-stds", "0,0.5", "--episodes", "4",
                             "--steps", "20", "--out", str(out)]) == 0
    rows = json.loads(out.read_text())["rows"]
    assert [(r["lead_steps"], r["asi_std"]) for r in rows] == [(0, 0.0), (0, 0.5), (2, 0.0), (2, 0.5)]
    assert all(0 < r["steps_survived"] <= 20 and r["heading_error_rad"] is not None for r in rows)
    # Led targets follow the reference closer than the step's own (the README's measurement, in small).
    assert rows[2]["reward_terms"]["end_effector"] > rows[0]["reward_terms"]["end_effector"]
    # ASI's spread perturbs the starts: a different (here worse or equal) tracking than the reference states.
    assert rows[1]["reward_terms"] != rows[0]["reward_terms"]


def test_bad_settings_exit_2(pd_tracking, capsys):
    assert pd_tracking.main(["--leads", "-1"]) == 2
    assert "--leads" in capsys.readouterr().err
