"""The asynchronous actor-learner loop end to end: workers sample while the learner updates,
batches carry a policy lag of at most --max-policy-lag, and the run resumes."""
from __future__ import annotations

import pytest

from services.training.driver import Trainer
from services.training.run_dir import read_metrics
from tests.integration.test_train_integration import small_config

pytestmark = pytest.mark.integration


@pytest.mark.parametrize("runner", ["processes", "ray"])
def test_async_training_runs_with_bounded_lag_and_resumes(tmp_path, runner):
    import ray

    out = tmp_path / runner
    try:
        Trainer(small_config(out, init="rsi", runner=runner, max_policy_lag=1, samples=5 * 256), progress=False).run()
        Trainer(small_config(out, init="rsi", runner=runner, max_policy_lag=1, samples=7 * 256), resume=True, progress=False).run()
    finally:
        ray.shutdown()
    rows = read_metrics(out)
    assert [r["samples"] for r in rows] == [256 * i for i in range(1, 8)]
    assert rows[0]["policy_lag"] == 0  # the first batch: nothing older exists
    assert all(0 <= r["policy_lag"] <= 1 for r in rows)
    assert any(r["policy_lag"] == 1 for r in rows[1:5])  # sampled while the learner updated
    assert all(max(r["batch_policy_versions"]) <= r["iteration"] - 1 for r in rows)
