"""A help that decays (`--residual-force-final`): the residual root wrench's strength falls over
the run, reaches the workers and the evaluations, is kept in every checkpoint, and a policy is
played at the strength it was trained at; best.pt is chosen only at the final strength."""
from __future__ import annotations

import numpy as np
import pytest

from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.envs.residual_force import ResidualForce
from actors.motion.formats.io import load_motion
from actors.rollout.worker import RolloutWorker
from learner.checkpoint import latest_checkpoint, load_checkpoint
from learner.errors import SfvError
from learner.schedule import decaying_help
from services.training.config import TrainConfig
from services.training.driver import Trainer
from services.training.run_dir import BEST_CHECKPOINT, load_run

BATCH = 128


def test_the_schedule_holds_falls_and_holds():
    strengths = [decaying_help(0.0, s, 1000) for s in (0, 250, 500, 750, 1000, 5000)]
    assert strengths == pytest.approx([1.0, 1.0, 0.5, 0.0, 0.0, 0.0])
    assert decaying_help(0.4, 500, 1000) == pytest.approx(0.7)


def test_a_wrench_at_strength_zero_is_the_body_alone():
    walk = load_motion("deepmimic:walk")
    plain = ImitationEnv(walk, EnvConfig())
    helped = ImitationEnv(walk, EnvConfig(residual_force=2.0, residual_force_scale=0.0))
    joints = plain.action_space.shape[0]
    up = np.zeros(joints + 6)
    up[joints + 2] = 1.0  # at full strength twice the body's weight upwards
    roots = []
    for env, action in ((plain, np.zeros(joints)), (helped, up)):
        env.reset(seed=0, options={"init": "fsi"})
        for _ in range(8):
            env.step(action)
        roots.append(env.data.qpos[:3].copy())
    np.testing.assert_array_equal(roots[1], roots[0])
    helped.set_residual_strength(0.5)
    assert helped.core.residual.scale[2] == pytest.approx(0.5 * 2.0 * helped.core.residual.weight_n)


def test_strength_is_checked():
    with pytest.raises(ValueError, match="strength must be in"):
        ResidualForce(0.5, 0.1, 10.0, 1, 1, strength=1.5)
    with pytest.raises(ValueError, match="residual_force_scale must be in"):
        EnvConfig(residual_force=0.5, residual_force_scale=-0.1)
    with pytest.raises(SfvError, match="--residual-force-final must be in"):
        TrainConfig(motion="deepmimic:walk", residual_force_final=2.0).validate()


class StrengthWorker(RolloutWorker):
    seen: list = []

    def sample(self, *args, **kwargs):
        StrengthWorker.seen.append(kwargs.get("residual_strength"))
        batch = super().sample(*args, **kwargs)
        assert self.env.core.residual.strength == pytest.approx(StrengthWorker.seen[-1])
        return batch


class StrengthTrainer(Trainer):
    worker_class = StrengthWorker


def test_a_decaying_run_hands_the_strength_to_workers_checkpoints_and_best(tmp_path):
    StrengthWorker.seen = []
    out = tmp_path / "run"
    config = TrainConfig(motion="deepmimic:walk", out=str(out), workers=1, envs_per_worker=4, init="rsi", samples=8 * BATCH,
                         runner="in_process", checkpoint_every=1, keep_checkpoints=20, plot_every=0, eval_every=BATCH,
                         eval_episodes=1, torch_threads=1, residual_force_final=0.0,
                         env=EnvConfig(residual_force=0.5, horizon_s=0.5))
    config.ppo.batch_size = config.ppo.minibatch_size = BATCH
    config.ppo.policy_hidden = config.ppo.value_hidden = (16,)
    StrengthTrainer(config, progress=False).run()
    # the strength each batch was collected at: 1 for the first quarter, then down to 0 by 3/4
    assert StrengthWorker.seen == pytest.approx([1.0, 1.0, 1.0, 0.75, 0.5, 0.25, 0.0, 0.0])
    saved = load_checkpoint(latest_checkpoint(out))
    assert saved["residual_force_scale"] == 0.0
    best = load_checkpoint(out / BEST_CHECKPOINT)
    assert best["samples"] >= 6 * BATCH and best["residual_force_scale"] == 0.0  # never an early, helped policy
    run_config, _ = load_run(out)
    assert run_config.env.residual_force_scale == 0.0 and run_config.env.residual_force == 0.5
