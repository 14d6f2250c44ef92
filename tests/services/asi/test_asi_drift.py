"""`asi/mean_shift_sigma` and `asi/std_ratio` in the training metrics: how far ASI moved;
`asi/weight_max` and `asi/fall_rate/<c>`: where its starts go."""
from __future__ import annotations

import json

from services.training.config import TrainConfig
from services.training.driver import Trainer
from services.training.run_dir import METRICS_FILE


def metrics_rows(tmp_path, rule: str, step: float) -> list[dict]:
    config = TrainConfig(out=str(tmp_path / rule), workers=1, envs_per_worker=8, samples=6 * 512, runner="in_process",
                         torch_threads=1, eval_every=0, plot_every=0, asi_episodes_per_update=20,
                         asi_update_rule=rule, asi_step_size=step)
    config.ppo.batch_size = config.ppo.minibatch_size = 512
    config.ppo.policy_hidden = config.ppo.value_hidden = (32,)
    Trainer(config, progress=False).run()
    rows = [json.loads(line) for line in (tmp_path / rule / METRICS_FILE).read_text().splitlines()]
    return [r for r in rows if "asi/mean_shift_sigma" in r]


def test_the_natural_rule_moves_asi_by_a_fraction_of_sigma(tmp_path):
    rows = metrics_rows(tmp_path, "natural", 0.2)
    natural = [(r["asi_version"], r["asi/mean_shift_sigma"], r["asi/std_ratio"]) for r in rows]
    assert natural[0][1:] == (0.0, 1.0)  # measured from the first distribution this process saw
    assert len({v for v, _, _ in natural}) == len(natural) >= 3  # a row per new version, not per iteration
    assert natural[-1][0] >= 3  # several steps taken
    assert 0.05 < natural[-1][1] < 0.5 * natural[-1][0]  # moved, and by less than the 0.5 sigma safeguard per step
    assert 0.9 < natural[-1][2] < 1.2
    # Where starts go: uniform at the default beta 0; a rate per component (0 here: the curriculum's
    # 0.5 s episodes end before an untrained walk falls; test_asi_fall_weighting checks the flags arrive).
    assert all(r["asi/weight_max"] == 0.1 for r in rows)
    assert all(0.0 <= rows[-1][f"asi/fall_rate/{c}"] <= 1.0 for c in range(10))


def test_rsi_runs_have_no_asi_figures(tmp_path):
    config = TrainConfig(out=str(tmp_path / "rsi"), workers=1, envs_per_worker=4, init="rsi", samples=512,
                         runner="in_process", torch_threads=1, eval_every=0, plot_every=0)
    config.ppo.batch_size = config.ppo.minibatch_size = 512
    config.ppo.policy_hidden = config.ppo.value_hidden = (16,)
    Trainer(config, progress=False).run()
    assert "asi/mean_shift_sigma" not in (tmp_path / "rsi" / METRICS_FILE).read_text()


def test_the_figures_follow_the_embedded_server_after_a_resume(tmp_path):
    # The embedded server starts its job again at version 0 on --resume, below the checkpoint's
    # version; the figures must follow its new updates, not wait until it passes the old count.
    def run(samples: int, resume: bool):
        config = TrainConfig(out=str(tmp_path / "run"), workers=1, envs_per_worker=8, samples=samples, runner="in_process",
                             torch_threads=1, eval_every=0, plot_every=0, asi_episodes_per_update=20)
        config.ppo.batch_size = config.ppo.minibatch_size = 512
        config.ppo.policy_hidden = config.ppo.value_hidden = (32,)
        Trainer(config, resume=resume, progress=False).run()

    run(8 * 512, resume=False)
    rows = [json.loads(line) for line in (tmp_path / "run" / METRICS_FILE).read_text().splitlines()]
    before = max(r["asi_version"] for r in rows)
    run(11 * 512, resume=True)
    rows = [json.loads(line) for line in (tmp_path / "run" / METRICS_FILE).read_text().splitlines()]
    after = [r for r in rows if r["samples"] > 8 * 512 and "asi/mean_shift_sigma" in r]
    # A row per new server version (the first one this process saw, then each update), while the
    # server's count stays below the checkpoint's.
    assert max(r["asi_version"] for r in rows if r["samples"] > 8 * 512) == before
    assert len(after) >= 2, (before, [(r["samples"], r["asi_version"]) for r in rows])
    assert after[0]["asi/mean_shift_sigma"] == 0.0 and after[-1]["asi/mean_shift_sigma"] > 0.0
