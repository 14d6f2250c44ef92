"""The episode-length curriculum (trainer schedule, worker cap) and loading run directories
written before the DeepMimic-faithful defaults."""
import numpy as np
import pytest

from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.envs.initial_states import BufferedStarts, ReferenceStarts
from actors.envs.vector_env import VectorImitationEnv
from services.training.config import TrainConfig
from services.training.driver import Trainer


def test_schedule_grows_linearly_from_the_start_cap_to_the_horizon(tmp_path):
    config = TrainConfig(out=str(tmp_path / "run"), curriculum_start_s=0.5, curriculum_samples=1_000_000)
    trainer = Trainer(config)
    trainer.samples = 0
    assert trainer._horizon_s() == pytest.approx(0.5)
    trainer.samples = 250_000
    assert trainer._horizon_s() == pytest.approx(0.5 + 0.25 * (config.env.horizon_s - 0.5))
    trainer.samples = 1_000_000
    assert trainer._horizon_s() is None  # over: the env's own horizon
    trainer.config.curriculum_start_s = 0.0
    trainer.samples = 0
    assert trainer._horizon_s() is None  # off


def test_capped_episodes_are_truncated_not_terminated(walk_clip):
    config = EnvConfig(horizon_s=4.0, early_termination=False)
    starts = BufferedStarts(ReferenceStarts("rsi", np.random.default_rng(0)), batch=8)
    venv = VectorImitationEnv(walk_clip, config, num_envs=2, starts=starts, seed=3)
    venv.set_horizon(0.5)  # 15 control steps
    venv.reset()
    lengths, ends = [0, 0], []
    for _ in range(40):
        _, _, terminated, truncated, _ = venv.step(np.zeros((2, venv.action_dim), np.float32))
        for i in range(2):
            lengths[i] += 1
            if terminated[i] or truncated[i]:
                ends.append((lengths[i], bool(terminated[i]), bool(truncated[i])))
                lengths[i] = 0
    assert ends and all(n == 15 and not term and trunc for n, term, trunc in ends)
    venv.set_horizon(None)
    assert venv.envs[0].horizon_cap_steps is None


def old_run_config() -> dict:
    """A config.json as runs wrote it before residual actions, strict falls and the DeepMimic reward."""
    d = TrainConfig().to_dict()
    for key in ("curriculum_start_s", "curriculum_samples", "asi_initial_std_scale", "eval_every", "eval_episodes"):
        d.pop(key)
    env = d["env"]
    for key in ("residual_action_scale", "ground_contact_links", "sync_root_per_cycle", "zero_reward_on_fall",
                "reference_obs_steps", "state_space"):
        env.pop(key)
    env["action_parameterisation"] = "axis_angle"
    env["reward"] = {"pose_weight": 0.65, "velocity_weight": 0.1, "end_effector_weight": 0.15, "com_weight": 0.1,
                     "pose_scale": 2.0, "velocity_scale": 0.1, "end_effector_scale": 40.0, "com_scale": 10.0}
    return d


def test_an_old_run_directory_gets_the_settings_it_was_trained_with(walk_clip):
    config = TrainConfig.from_dict(old_run_config())
    env = ImitationEnv(walk_clip, config.env)
    assert env.action_space.shape == (36,) and not env.actions.residual
    assert config.env.sfv.reward.form == "sfv_paper" and env.max_reward == pytest.approx(1.0)
    assert env.obs_dim == 197 and env.state_dim == 75  # SFV's observation, qpos-space ASI states
    assert sorted(env.fall_detector.links) == [0, 1, 2]  # root, chest, neck: the old rule
    assert config.curriculum_start_s == 0.0 and config.asi_initial_std_scale == 1.0


def test_a_run_from_before_ballistic_flight_starts_keeps_the_references_velocities():
    d = TrainConfig().to_dict()
    assert d["env"]["flight_starts"] == "ballistic"
    del d["env"]["flight_starts"]
    assert TrainConfig.from_dict(d).env.flight_starts == "reference"


def test_a_run_from_before_the_tracking_termination_keeps_training_without_it():
    d = TrainConfig().to_dict()
    assert d["env"]["sfv"]["tracking_termination_m"] == 1.0
    del d["env"]["sfv"]
    assert TrainConfig.from_dict(d).env.sfv.tracking_termination_m == 0.0


def test_a_config_from_another_version_names_the_field():
    from learner.errors import ConfigError

    d = TrainConfig().to_dict()
    d["no_such_field"] = 1
    with pytest.raises(ConfigError, match="no_such_field"):
        TrainConfig.from_dict(d)


def test_a_g1_run_from_before_the_per_joint_residual_range_keeps_0_5_rad_on_every_joint():
    d = TrainConfig().to_dict()
    assert d["env"]["residual_scale_per_joint"] is True
    d["env"]["character"] = "g1"
    del d["env"]["residual_scale_per_joint"]
    assert TrainConfig.from_dict(d).env.residual_scale_per_joint is False
    d["env"]["character"] = "humanoid3d"  # its factors are all 1: nothing to keep
    assert TrainConfig.from_dict(d).env.residual_scale_per_joint is True
