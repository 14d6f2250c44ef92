"""The golden digests in bench/results/ match the code: the default (synchronous) training path gives
the recorded rollout and weights to the bit on the recording's platform, and the same numbers elsewhere.

A deliberate behaviour change rewrites the file (`python bench/scripts/golden.py --out
bench/results/golden_digests.json`) with the reason in the commit message."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.bench_scripts import load_bench_script

GOLDEN_FILE = Path(__file__).resolve().parents[2] / "bench" / "results" / "golden_digests.json"


@pytest.fixture(scope="module")
def golden():
    pytest.importorskip("pybullet_data", reason="the golden runs train on DeepMimic's walk")
    return load_bench_script("golden")


@pytest.fixture(scope="module")
def recorded() -> dict:
    return json.loads(GOLDEN_FILE.read_text())


@pytest.fixture(scope="module")
def recomputed(golden) -> dict:
    return golden.compute()


def test_the_digests_match_the_record_to_the_bit_on_its_platform(golden, recorded, recomputed):
    if golden.platform() != recorded[golden.PLATFORM_KEY]:
        pytest.skip(f"bits are compared on the recording's platform only: {recorded[golden.PLATFORM_KEY]}")
    changed = golden.changed_digests(recorded, recomputed)
    assert not changed, (f"{GOLDEN_FILE.name}: {changed} differ; if the change is deliberate, rewrite it with "
                         "bench/scripts/golden.py --out and give the reason in the commit")


def test_the_rollout_reward_and_sample_counts_match_the_record_on_any_platform(recorded, recomputed):
    assert recomputed["rollout_reward_sum"] == pytest.approx(recorded["rollout_reward_sum"], rel=1e-3)
    assert (recomputed["rsi_samples"], recomputed["asi_samples"]) == (recorded["rsi_samples"], recorded["asi_samples"])


def test_a_changed_entry_is_named_and_the_platform_is_not_compared(golden, recorded):
    altered = dict(recorded, rollout_sha256="0" * 64, platform={"cpu": "another"})
    assert golden.changed_digests(recorded, altered) == ["rollout_sha256"]
