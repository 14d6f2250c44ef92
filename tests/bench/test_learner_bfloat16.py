"""bench/scripts/learner_bfloat16.py: its update timing runs both precisions and parses its flags."""
import pytest

from tests.bench_scripts import load_bench_script


def test_the_update_timing_runs_a_full_update_in_both_precisions():
    script = load_bench_script("learner_bfloat16")
    seconds = {bf16: script.update_seconds(bf16, threads=1, samples=512) for bf16 in (False, True)}
    assert all(0.0 < s < 60.0 for s in seconds.values())


def test_the_script_needs_an_output_path():
    script = load_bench_script("learner_bfloat16")
    with pytest.raises(SystemExit):
        script.main([])
