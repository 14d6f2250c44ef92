"""`sfv train --start-from RUN`: another run's weights start a training (the pipeline's body-alone stage)."""
from __future__ import annotations

import logging

import pytest

from learner.errors import SfvError


def tiny(out, **env):
    from actors.envs.imitation_env import EnvConfig
    from services.training.config import TrainConfig

    config = TrainConfig(motion="deepmimic:walk", out=str(out), workers=1, envs_per_worker=2, init="rsi", samples=128,
                         runner="in_process", eval_every=0, env=EnvConfig(**env))
    config.ppo.batch_size, config.ppo.minibatch_size = 128, 128
    config.ppo.policy_hidden, config.ppo.value_hidden = (32,), (16,)
    return config


@pytest.mark.slow
def test_a_run_starts_from_the_helped_run_s_weights_without_its_wrench(tmp_path, caplog):
    from services.training.driver import Trainer

    Trainer(tiny(tmp_path / "helped", residual_force=0.5), progress=False).run()
    alone = tiny(tmp_path / "alone")
    alone.start_from = str(tmp_path / "helped")
    with caplog.at_level(logging.INFO, logger="sfv.train"):
        Trainer(alone, progress=False).run()
    said = [r.getMessage() for r in caplog.records if r.getMessage().startswith("started from ")]
    assert said == [f"started from {tmp_path / 'helped' / 'checkpoint_000000001.pt'} (its last 6 action numbers dropped)"]
    missing = tiny(tmp_path / "other")
    missing.start_from = str(tmp_path / "nowhere")
    with pytest.raises(SfvError, match="--start-from .*nowhere: no such run directory or checkpoint"):
        Trainer(missing, progress=False).run()
