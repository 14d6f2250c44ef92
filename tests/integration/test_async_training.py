"""The asynchronous actor-learner loop end to end: workers sample while the learner updates,
batches carry a policy lag of at most --max-policy-lag, and the run resumes."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from services.training.run_dir import read_metrics

REPO = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.integration


@pytest.mark.parametrize("runner", ["processes", "ray"])
def test_async_training_runs_with_bounded_lag_and_resumes(tmp_path, runner):
    out = tmp_path / runner
    done = subprocess.run([sys.executable, "-m", "tests.integration.async_training_scenario", runner, str(out)],
                          capture_output=True, text=True, timeout=900, cwd=REPO)
    assert done.returncode == 0, done.stderr[-2000:]
    rows = read_metrics(out)
    assert [r["samples"] for r in rows] == [256 * i for i in range(1, 8)]
    assert rows[0]["policy_lag"] == 0  # the first batch: nothing older exists
    assert all(0 <= r["policy_lag"] <= 1 for r in rows)
    assert any(r["policy_lag"] == 1 for r in rows[1:5])  # sampled while the learner updated
    assert all(max(r["batch_policy_versions"]) <= r["iteration"] - 1 for r in rows)
