"""A run directory on a synthetic standing clip with a small untrained checkpoint (tests of
evaluation, recording and distillation that need a real 'expert' run)."""
from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path


def write_stand_run(root: Path, motion, edit_policy: Callable | None = None, hidden: tuple[int, int] = (32, 16)) -> Path:
    """`root`/run with config.json and checkpoint 1; `edit_policy(learner.policy)` runs under no_grad before saving."""
    import torch

    from actors.character.features import observation_dim
    from actors.envs.imitation_env import EnvConfig
    from actors.motion.formats.io import save_motion
    from learner.checkpoint import checkpoint_path, save_checkpoint
    from learner.ppo import PPOLearner
    from services.training.config import TrainConfig
    from services.training.run_dir import CONFIG_FILE

    motion_file = save_motion(motion, root / "stand.npz")
    run = root / "run"
    run.mkdir()
    config = TrainConfig(motion=str(motion_file), out=str(run), init="rsi", runner="in_process", env=EnvConfig(horizon_s=2.0))
    config.ppo.policy_hidden, config.ppo.value_hidden = (hidden[0],), (hidden[1],)
    (run / CONFIG_FILE).write_text(json.dumps(config.to_dict()))
    learner = PPOLearner(observation_dim(len(config.env.reference_obs_steps)), 28, config.ppo)
    if edit_policy is not None:
        with torch.no_grad():
            edit_policy(learner.policy)
    save_checkpoint(checkpoint_path(run, 1), {"learner": learner.state_dict(), "policy_weights": learner.policy_weights(),
                                              "samples": 128, "iteration": 1, "asi_version": 0, "config": config.to_dict()})
    return run
