"""bench/scripts/golden.py's digests: a serial run is reproducible to the bit (so a restructuring can
be checked against them), and they do change when the behaviour does."""
from __future__ import annotations

import pytest

from tests.bench_scripts import load_bench_script


@pytest.fixture(scope="module")
def golden():
    return load_bench_script("golden")


def test_two_serial_asi_trainings_give_the_same_weights_to_the_bit(golden):
    first, second = golden._training_digest("asi"), golden._training_digest("asi")
    assert first == second and first["asi_samples"] == 2048


def test_the_rollout_digest_is_reproducible_and_sees_a_changed_array(golden):
    import numpy as np

    assert golden._rollout_digest() == golden._rollout_digest()
    a = {"x": np.zeros(3, np.float32)}
    b = {"x": np.array([0.0, 0.0, 1e-30], np.float32)}
    assert golden._digest(a) != golden._digest(b)
