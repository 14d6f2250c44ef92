"""bench/scripts/start_velocity_probe.py: a run's policy replayed with start velocities filtered."""
from __future__ import annotations

import json

import numpy as np
import pytest

from actors.motion.reference_motion import ReferenceMotion
from learner.errors import SfvError
from tests.bench_scripts import load_bench_script
from tests.stand_run import write_stand_run

STAND_HEIGHT = 0.87


@pytest.fixture(scope="module")
def probe():
    return load_bench_script("start_velocity_probe")


@pytest.fixture(scope="module")
def jittery_stand_run(tmp_path_factory):
    """Standing still, its root 15 cm up on one frame: a one-frame jitter, the roll's kind of spike."""
    frames = 31
    root_pos = np.tile([0.0, 0.0, STAND_HEIGHT], (frames, 1))
    root_pos[16, 2] += 0.15  # the start at phase .5 (row 15) gets 2.25 m/s upwards from it
    joint_rot = np.zeros((frames, 12, 4))
    joint_rot[..., 0] = 1.0
    root_rot = np.zeros((frames, 4))
    root_rot[:, 0] = 1.0
    motion = ReferenceMotion("jitter_stand", np.linspace(0.0, 1.0, frames), root_pos, root_rot, joint_rot, loop=True)

    def zero_residual(policy):  # the character holds the reference
        policy.mean_net[-1].weight.zero_()
        policy.mean_net[-1].bias.zero_()

    return write_stand_run(tmp_path_factory.mktemp("probe"), motion, zero_residual)


def test_each_window_is_evaluated_and_written(probe, jittery_stand_run, tmp_path, capsys):
    out = tmp_path / "probe.json"
    assert probe.main([str(jittery_stand_run), "--windows", "1,3", "--episodes", "4", "--out", str(out)]) == 0
    doc = json.loads(out.read_text())
    own, median = doc["windows"]
    assert [own["median_rows"], median["median_rows"]] == [1, 3] and doc["episodes"] == 4
    for row in (own, median):
        assert len(row["start_returns"]) == 4 and 0.0 < row["normalized_return"] <= 1.0 and row["falls"] == 0
    # The only difference between the rows is the start at .5: 2.25 m/s up with the clip's own velocities, 0 filtered.
    assert own["start_returns"][:2] == median["start_returns"][:2] and own["start_returns"][3] == median["start_returns"][3]
    assert own["start_returns"][2][0] == 0.5 and own["start_returns"][2][1] < median["start_returns"][2][1] - 0.01
    assert capsys.readouterr().out.count("median over") == 2


def test_bad_windows_are_one_line_and_write_nothing(probe, tmp_path, capsys):
    out = tmp_path / "probe.json"
    assert probe.main([str(tmp_path), "--windows", "2", "--out", str(out)]) == 2
    assert "odd row counts" in capsys.readouterr().err and not out.exists()
    with pytest.raises(SfvError, match="'x'"):
        probe.parse_windows("x")
    assert probe.parse_windows("1,3,5") == [1, 3, 5]
