"""bench/scripts/flight_momentum.py: the backflip's flight is found where physics says it is."""
from __future__ import annotations

from tests.bench_scripts import load_bench_script


def test_the_backflips_longest_flight_falls_near_g_and_its_momentum_is_reported():
    script = load_bench_script("flight_momentum")
    result = script.reference_flight("backflip")
    assert len(result["airborne_per_row"]) == result["start_rows"] == len(result["angular_momentum_norm_per_row"])
    flight = max(result["flights"], key=lambda f: f["seconds"])
    assert 0.3 < flight["seconds"] < 0.8, "a backflip is in the air for about half a second"
    assert -12.0 < flight["com_vertical_acceleration"] < -7.0, "in the air the centre of mass falls at about g"
    first, last = flight["angular_momentum_norm_first_last"]
    assert first > 5.0 and last > 5.0, "it rotates through the flight"


def test_ballistic_starts_carry_one_momentum_inside_the_references_range():
    script = load_bench_script("flight_momentum")
    result = script.reference_flight("backflip")
    ballistic = max(result["ballistic_flights"], key=lambda f: f["phases"][1] - f["phases"][0])
    flight = max(result["flights"], key=lambda f: f["seconds"])
    assert abs(ballistic["phases"][0] - flight["phases"][0]) < 0.05
    norms = [n for n, a in zip(result["angular_momentum_norm_per_row"], result["airborne_per_row"]) if a]
    assert min(norms) < ballistic["angular_momentum_norm"] < max(norms)
