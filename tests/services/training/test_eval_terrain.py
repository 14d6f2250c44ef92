"""`sfv eval --terrain`: a run trained on the flat floor evaluated on terrain (blind), and one-line
errors for a terrain name or difficulty that is not one."""
from __future__ import annotations

import json

import pytest

from services.cli import main
from tests.services.training.test_eval_first_frame import _hold, _run


def test_a_flat_run_stands_blind_on_a_flat_height_field_as_on_the_floor(tmp_path, capsys):
    """The run has no heightmap in its observation, so the eval env leaves it out; difficulty 0 is
    a flat field, which holds the stand as the plane does (NR .978 against .999, measured: the
    field's contacts are triangles, not the plane's)."""
    run = _run(tmp_path, loop=True, edit=_hold)
    assert main(["eval", str(run), "--episodes", "2", "--terrain", "mixed", "--terrain-difficulty", "0", "--terrain-seed", "3"]) == 0
    field = json.loads(capsys.readouterr().out)
    assert main(["eval", str(run), "--episodes", "2"]) == 0
    flat = json.loads(capsys.readouterr().out)
    assert field["fall_rate"] == flat["fall_rate"] == 0.0
    assert field["normalized_return"] == pytest.approx(flat["normalized_return"], abs=0.05)


@pytest.mark.parametrize("flags, message", [
    (["--terrain", "stairs"], "sfv: eval: --terrain must be one of slopes, gaps, steps, rough, mixed, got 'stairs'"),
    (["--terrain", "gaps", "--terrain-difficulty", "1.5"], "sfv: eval: --terrain-difficulty must lie in [0, 1], got 1.5"),
    (["--terrain", "gaps", "--terrain-seed", "x"], "sfv: eval: --terrain-seed must be an integer, got 'x'"),
    (["--terrain-difficulty", "0.5"], "sfv: eval: --terrain-difficulty and --terrain-seed need --terrain KIND (the run trained on the flat floor)"),
])
def test_bad_terrain_flags_are_one_line_naming_the_flag(tmp_path, capsys, flags, message):
    run = _run(tmp_path, loop=True, edit=_hold)
    assert main(["eval", str(run), "--episodes", "1", *flags]) != 0
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.strip() == message
