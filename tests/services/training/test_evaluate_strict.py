"""Strict evaluation (`services/training/evaluation.py`, `sfv eval`, the trainer's periodic eval, the plot).

Most tests use a synthetic clip: the character standing still (every joint at rest), which PD
tracking with a zero residual holds for seconds, so "not fallen" has a real control case. The
walk (DeepMimic, pybullet_data) is used where a travelling or moving reference matters.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from actors.character import quaternion as qn
from actors.character.actions import ActionMapper
from actors.character.features import update_kinematics
from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.motion.reference_motion import ReferenceMotion
from actors.character.skeleton import JOINT_IS_SPHERICAL, JOINT_NAMES, LINK_NAMES
from services.cli import main
from services.training.evaluation import DEFAULT_EPISODES, TrainingEvaluator, evaluate_policy, make_eval_env
from services.training.strict_episode import PUSH_RECOVERY_S
from services.training.tracking_error import tracking_errors

STAND_HEIGHT = 0.885  # root height at which the rest pose's feet just touch the floor
REVOLUTE_NAMES = [n for n, s in zip(JOINT_NAMES, JOINT_IS_SPHERICAL) if not s]


def stand_motion(seconds: float = 2.0, loop: bool = True, name: str = "stand") -> ReferenceMotion:
    frames = 3
    joint_rot = np.zeros((frames, 12, 4))
    joint_rot[..., 0] = 1.0
    root_rot = np.zeros((frames, 4))
    root_rot[:, 0] = 1.0
    root_pos = np.tile([0.0, 0.0, STAND_HEIGHT], (frames, 1))
    return ReferenceMotion(name, np.linspace(0.0, seconds, frames), root_pos, root_rot, joint_rot, loop=loop)


class Constant:
    """A policy that outputs the same action whatever it sees (batch of one)."""

    def __init__(self, action):
        self.action = np.asarray(action, np.float32)[None]
        self.calls = 0

    def act(self, obs, deterministic=True):
        assert deterministic and obs.shape[0] == 1
        self.calls += 1
        return self.action, np.zeros(1, np.float32)


class PhaseSpy(Constant):
    """Zero action; records the phase (the observation's last entry) it is shown at each call."""

    def __init__(self, dim):
        super().__init__(np.zeros(dim))
        self.phases = []

    def act(self, obs, deterministic=True):
        self.phases.append(float(obs[0, -1]))
        return super().act(obs, deterministic)


def kneel_action(env_config: EnvConfig) -> np.ndarray:
    """Absolute PD targets: every joint at rest but both knees fully bent (the character drops)."""
    mapper = ActionMapper(env_config.action_parameterisation, env_config.residual_action_scale)
    targets = np.zeros(28)
    for knee in ("right_knee", "left_knee"):
        targets[24 + REVOLUTE_NAMES.index(knee)] = -3.1
    return mapper.action_for_targets(targets)


ABSOLUTE = dict(residual_action_scale=None)  # absolute targets: the kneel policy bends the knees for real


@pytest.fixture(scope="module")
def stand():
    return stand_motion()


@pytest.fixture(scope="module")
def walk(walk_clip):
    return walk_clip


# ------------------------------------------------------------------------- strict falls
@pytest.mark.parametrize("early_termination", [False, True])
def test_kneeling_counts_as_a_fall_whatever_the_training_termination(stand, early_termination):
    config = EnvConfig(horizon_s=1.5, early_termination=early_termination, **ABSOLUTE)
    env = ImitationEnv(stand, config)
    rest = Constant(np.zeros(env.action_space.shape))
    kneel = Constant(kneel_action(config))
    held = evaluate_policy(rest, env, 4)
    assert held["fall_rate"] == 0.0 and held["episode_seconds"] == pytest.approx(1.5)
    knelt = evaluate_policy(kneel, env, 4)
    assert knelt["fall_rate"] == 1.0
    assert knelt["episode_seconds"] < 1.0 and knelt["normalized_return"] < 0.5 * held["normalized_return"]
    assert env.config.early_termination is early_termination  # the env's own setting is given back


def test_fall_phases_say_where_in_the_clip_each_fall_happened(stand):
    config = EnvConfig(horizon_s=1.5, early_termination=True, **ABSOLUTE)
    env = ImitationEnv(stand, config)
    assert evaluate_policy(Constant(np.zeros(env.action_space.shape)), env, 4)["fall_phases"] == []
    knelt = evaluate_policy(Constant(kneel_action(config)), env, 4)
    phases = np.array(knelt["fall_phases"])
    assert len(phases) == 4 and np.all(np.diff(phases) >= 0)
    # Episode k starts at phase k / 4 and falls within a second: its fall lies that far on in the clip.
    starts = np.arange(4) / 4
    later = np.mod(phases[:, None] - starts[None, :], 1.0) * stand.duration
    assert np.all(np.sort(later.min(axis=0)) < 1.0) and np.all(later.min(axis=0) > 0.0)
    falls = knelt["fall_starts"]
    assert [f["start_phase"] for f in falls] == pytest.approx(starts, abs=1.0 / (30 * stand.duration))
    assert all(0.0 < f["seconds"] < 1.0 for f in falls)


def test_start_returns_name_each_episodes_start_and_score(stand):
    config = EnvConfig(horizon_s=1.5, early_termination=True, **ABSOLUTE)
    env = ImitationEnv(stand, config)
    held = evaluate_policy(Constant(np.zeros(env.action_space.shape)), env, 4)
    knelt = evaluate_policy(Constant(kneel_action(config)), env, 4)
    for figures in (held, knelt):
        starts, scores = np.array(figures["start_returns"]).T
        assert starts == pytest.approx(np.arange(4) / 4, abs=1.0 / (30 * stand.duration))
        assert scores.mean() == pytest.approx(figures["normalized_return"], abs=1e-3)
    # Start by start, the kneeling policy scores below the one that holds the pose.
    assert np.all(np.array(knelt["start_returns"])[:, 1] < np.array(held["start_returns"])[:, 1])


def test_without_termination_the_env_alone_lets_the_kneeling_character_go_on(stand):
    """The control case for the test above: the env itself would not have ended these episodes."""
    config = EnvConfig(horizon_s=1.5, early_termination=False, **ABSOLUTE)
    env = ImitationEnv(stand, config)
    env.reset(options={"init": "fsi"})
    action = kneel_action(config)
    ended = [any(env.step(action)[2:4]) for _ in range(44)]
    assert not any(ended)
    assert env.data.qpos[2] < 0.4  # and it was down there


def test_lying_still_is_a_fall_even_where_every_link_may_touch_the_ground(stand):
    """With every link allowed on the ground the contact rule never fires: the pelvis floor does."""
    config = EnvConfig(horizon_s=2.0, early_termination=False, ground_contact_links=LINK_NAMES, **ABSOLUTE)
    env = ImitationEnv(stand, config)
    assert evaluate_policy(Constant(np.zeros(env.action_space.shape)), env, 2)["fall_rate"] == 0.0
    down = evaluate_policy(Constant(kneel_action(config)), env, 2)
    assert down["fall_rate"] == 1.0 and down["episode_seconds"] < 1.5


def test_a_divergence_ends_the_episode_as_a_fall(stand, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # MuJoCo writes MUJOCO_LOG.TXT on a simulation warning
    env = make_eval_env(stand, EnvConfig(horizon_s=1.0))

    class Blowup(Constant):
        def act(self, obs, deterministic=True):
            env.data.qvel[:] = 1e30  # the next step diverges; MuJoCo resets its state
            return super().act(obs, deterministic)

    result = evaluate_policy(Blowup(np.zeros(env.action_space.shape)), env, 2)
    assert result["fall_rate"] == 1.0 and result["divergences"] == 2 and result["episode_length"] == 1.0


# ------------------------------------------------------------------------ start phases
def test_episodes_start_at_evenly_spaced_phases(stand):
    env = make_eval_env(stand, EnvConfig(horizon_s=2 / 30))  # two control steps an episode
    spy = PhaseSpy(env.action_space.shape[0])
    episodes = 8
    result = evaluate_policy(spy, env, episodes)
    assert result["episode_length"] == 2.0 and len(spy.phases) == 2 * episodes
    starts = np.array(spy.phases[::2])
    grid = env.track.start_steps
    np.testing.assert_allclose(starts, np.arange(episodes) / episodes, atol=0.5 / grid + 1e-9)
    assert len(set(np.round(starts * grid).astype(int))) == episodes  # eight different grid rows
    again = PhaseSpy(env.action_space.shape[0])
    evaluate_policy(again, env, episodes, seed=123)
    assert again.phases == spy.phases  # the same episodes every time


def test_non_looped_episodes_run_from_their_start_phase_to_the_clip_end():
    env = make_eval_env(stand_motion(loop=False), EnvConfig())
    result = evaluate_policy(Constant(np.zeros(env.action_space.shape)), env, 4)
    assert result["distance_ratio"] is None
    # Later starts leave less of the clip: the mean length is that of the four remaining spans.
    grid = env.track.start_steps
    assert grid == 60  # 2 s at 30 Hz
    expected = np.mean([grid - round(grid * k / 4) for k in range(4)])  # 60, 45, 30, 15 steps
    assert result["episode_length"] == pytest.approx(expected)


# ------------------------------------------------------------------------------ pushes
def test_pushes_are_reported_and_a_huge_one_topples_a_passive_policy(stand):
    env = make_eval_env(stand, EnvConfig(horizon_s=2.0))
    passive = Constant(np.zeros(env.action_space.shape))
    plain = evaluate_policy(passive, env, 4)
    assert "push_survival_rate" not in plain and plain["fall_rate"] == 0.0
    gentle = evaluate_policy(passive, env, 4, pushes=2, push_impulse=1.0)
    assert gentle["pushes"] == 2 and gentle["push_episodes"] == 4
    assert gentle["push_survival_rate"] == 1.0 and gentle["fall_rate"] == 0.0
    huge = evaluate_policy(passive, env, 4, pushes=2, push_impulse=400.0)
    assert huge["push_impulse_ns"] == 400.0 and huge["push_episodes"] == 4
    assert huge["push_survival_rate"] == 0.0 and huge["fall_rate"] == 1.0
    assert huge["episode_seconds"] < 2.0 - PUSH_RECOVERY_S + 0.1  # down before the recovery window
    assert not env.data.xfrc_applied.any()  # no force left on the body


def test_episodes_too_short_for_the_pushes_are_not_counted_as_survived(stand):
    env = make_eval_env(stand, EnvConfig(horizon_s=1.0))  # 0.5 s settling + 1 s recovery: no room
    result = evaluate_policy(Constant(np.zeros(env.action_space.shape)), env, 2, pushes=1, push_impulse=400.0)
    assert result["push_episodes"] == 0 and result["push_survival_rate"] is None and result["fall_rate"] == 0.0


# ------------------------------------------------------------------------ error metrics
def _features(env, edit=None, row=0):
    env.set_reference_state(row)
    if edit is not None:
        edit(env.data)
        update_kinematics(env.model, env.data)
    sim = env.features.reward_features_of(env.data)
    from actors.character.features import RewardFeatures

    return RewardFeatures(sim.values.copy()), env.track.reward_features(row)


def test_errors_vanish_on_the_reference(walk):
    env = ImitationEnv(walk, EnvConfig(horizon_s=2.0))
    for row in (0, 9, 23, env.track.start_steps - 1):
        rotation, end_effector = tracking_errors(*_features(env, row=row))
        assert rotation[0] == pytest.approx(0.0, abs=1e-6) and end_effector[0] == pytest.approx(0.0, abs=1e-9)


def test_known_joint_offsets_give_their_angle(walk):
    env = ImitationEnv(walk, EnvConfig(horizon_s=2.0))
    shoulder = env.humanoid.joint_qpos_adr[JOINT_NAMES.index("right_shoulder")]
    knee = env.humanoid.joint_qpos_adr[JOINT_NAMES.index("right_knee")]
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])

    def twist_shoulder(data):
        offset = np.concatenate(([np.cos(0.15)], np.sin(0.15) * axis))  # 0.3 rad
        data.qpos[shoulder:shoulder + 4] = qn.quat_mul(data.qpos[shoulder:shoulder + 4], offset)

    def bend_knee(data):
        data.qpos[knee] -= 0.2

    rotation, end_effector = tracking_errors(*_features(env, twist_shoulder, row=12))
    assert rotation[0] == pytest.approx(0.3 / 12, abs=1e-6) and end_effector[0] > 0.01  # the wrist moved
    rotation, _ = tracking_errors(*_features(env, bend_knee, row=12))
    assert rotation[0] == pytest.approx(0.2 / 12, abs=1e-6)
    rotation, _ = tracking_errors(*_features(env, lambda d: (twist_shoulder(d), bend_knee(d)), row=12))
    assert rotation[0] == pytest.approx(0.5 / 12, abs=1e-6)


def test_end_effector_error_is_a_distance_in_the_heading_frame(walk):
    env = ImitationEnv(walk, EnvConfig(horizon_s=2.0))

    def lift(data):
        data.qpos[2] += 0.1  # every end effector 10 cm higher, nothing else changes

    def turn_and_move(data):  # a yaw and a horizontal shift: the heading frame sees nothing
        data.qpos[3:7] = qn.quat_mul(np.array([np.cos(0.6), 0.0, 0.0, np.sin(0.6)]), data.qpos[3:7])
        data.qpos[:2] += (2.0, -1.0)

    rotation, end_effector = tracking_errors(*_features(env, lift, row=5))
    assert end_effector[0] == pytest.approx(0.1, abs=1e-9) and rotation[0] == pytest.approx(0.0, abs=1e-6)
    rotation, end_effector = tracking_errors(*_features(env, turn_and_move, row=5))
    assert end_effector[0] == pytest.approx(0.0, abs=1e-9) and rotation[0] == pytest.approx(0.0, abs=1e-6)


def test_a_bent_knee_shows_in_the_episode_errors(stand):
    """End to end: holding one knee 0.5 rad off the reference raises the measured errors."""
    config = EnvConfig(horizon_s=1.0)
    env = make_eval_env(stand, config)
    straight = evaluate_policy(Constant(np.zeros(28)), env, 2)
    action = np.zeros(28)
    action[24 + REVOLUTE_NAMES.index("right_knee")] = -1.0  # residual: reference - 0.5 rad
    bent = evaluate_policy(Constant(action), env, 2)
    assert straight["joint_rotation_error_rad"] < 0.01
    assert bent["joint_rotation_error_rad"] > 0.5 * 0.5 / 12  # at least half the commanded offset, on average
    assert bent["end_effector_error_m"] > 2 * straight["end_effector_error_m"]


def test_distance_ratio(walk, stand):
    env = make_eval_env(walk, EnvConfig(horizon_s=0.5))
    one = evaluate_policy(Constant(np.zeros(28)), env, 1)
    assert one["fall_rate"] == 0.0
    # Recomputed from where the env was left: episode 0 starts on row 0 and ends on env.row.
    travelled = np.linalg.norm(env.data.qpos[:2] - env.track.qpos[0, :2])
    clip = np.linalg.norm(env.track.qpos[env.row, :2] - env.track.qpos[0, :2])
    assert clip > 0.3 and one["distance_ratio"] == pytest.approx(travelled / clip, rel=1e-9)
    tracking = evaluate_policy(Constant(np.zeros(28)), env, 4)
    assert 0.5 < tracking["distance_ratio"] < 1.5  # PD tracking of the walk travels about as far as the clip
    assert evaluate_policy(Constant(np.zeros(28)), make_eval_env(stand, EnvConfig(horizon_s=0.5)), 2)["distance_ratio"] is None


# ----------------------------------------------------------------------------- sfv eval
@pytest.fixture(scope="module")
def stand_run(tmp_path_factory):
    """A run directory on the standing clip with a real (untrained, small) checkpoint."""
    from tests.stand_run import write_stand_run

    def zero_residual(policy):  # the character holds the reference
        policy.mean_net[-1].weight.zero_()
        policy.mean_net[-1].bias.zero_()

    return write_stand_run(tmp_path_factory.mktemp("evalrun"), stand_motion(), zero_residual)


def test_sfv_eval_prints_one_json_object(stand_run, capsys):
    assert main(["eval", str(stand_run), "--episodes", "3"]) == 0
    out = capsys.readouterr().out
    assert out.count("\n") == 1
    result = json.loads(out)
    assert result["episodes"] == 3 and result["fall_rate"] == 0.0 and result["episode_seconds"] == pytest.approx(2.0)
    assert 0.9 < result["normalized_return"] <= 1.0 and result["joint_rotation_error_rad"] < 0.05
    assert {"normalized_return_std", "episode_length", "end_effector_error_m", "distance_ratio"} <= set(result)
    assert "push_survival_rate" not in result
    assert main(["eval", str(stand_run), "--episodes", "2", "--push", "1", "--push-impulse", "400"]) == 0
    pushed = json.loads(capsys.readouterr().out)
    assert pushed["pushes"] == 1 and pushed["push_impulse_ns"] == 400.0 and pushed["push_survival_rate"] == 0.0


def test_sfv_eval_defaults_to_the_documented_episode_count():
    from services.cli import build_parser

    args = build_parser().parse_args(["eval", "run"])
    assert int(args.episodes) == DEFAULT_EPISODES == 32


@pytest.mark.parametrize("argv, flag", [
    (["--episodes", "0"], "--episodes"),
    (["--episodes", "many"], "--episodes"),
    (["--push", "-1"], "--push"),
    (["--push", "1.5"], "--push"),
    (["--push-impulse", "-3"], "--push-impulse"),
    (["--push-impulse", "nan"], "--push-impulse"),
    (["--push-duration", "0"], "--push-duration"),
    (["--seed", "x"], "--seed"),
])
def test_bad_flag_values_are_one_line_errors(argv, flag, tmp_path, capsys):
    assert main(["eval", str(tmp_path), *argv]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert err.startswith("sfv: eval: ") and flag in err and "\n" not in err and captured.out == ""


# ------------------------------------------------------------------------------ training
def test_training_evaluates_when_the_sample_count_crosses_eval_every_and_at_the_end(tmp_path):
    from actors.motion.formats.io import save_motion
    from services.training.config import TrainConfig
    from services.training.driver import Trainer
    from services.training.run_dir import read_metrics

    motion = save_motion(stand_motion(), tmp_path / "stand.npz")
    config = TrainConfig(motion=str(motion), out=str(tmp_path / "run"), workers=1, envs_per_worker=4, init="rsi",
                         samples=4 * 128, runner="in_process", plot_every=1, plot_min_interval_s=0.0, eval_every=200,
                         eval_episodes=2, env=EnvConfig(horizon_s=1.0))
    config.ppo.batch_size, config.ppo.minibatch_size = 128, 128
    config.ppo.policy_hidden, config.ppo.value_hidden = (32,), (16,)
    Trainer(config, progress=False).run()
    rows = read_metrics(tmp_path / "run")
    assert [r["samples"] for r in rows] == [128, 256, 384, 512]
    evaluated = [r["samples"] for r in rows if "eval/normalized_return" in r]
    assert evaluated == [256, 512]  # crossed 200 and 400 (at 512, also the end)
    for row in rows:
        if "eval/normalized_return" in row:
            assert row["eval/episodes"] == 2 and 0.0 <= row["eval/normalized_return"] <= 1.0
            assert 0.0 <= row["eval/fall_rate"] <= 1.0 and 0.0 < row["eval/episode_seconds"] <= 1.0
            assert row["eval/joint_rotation_error_rad"] >= 0.0 and row["eval/end_effector_error_m"] >= 0.0
            assert "eval/distance_ratio" in row
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    events = EventAccumulator(str(tmp_path / "run" / "tb"))
    events.Reload()
    scalars = events.Tags()["scalars"]
    assert "eval/normalized_return" in scalars and "eval/fall_rate" in scalars
    assert [e.step for e in events.Scalars("eval/normalized_return")] == [256, 512]
    assert (tmp_path / "run" / "learning_curve.png").is_file()


def test_training_evaluator_uses_the_current_weights(stand):
    """The evaluator reloads the policy it is given each time (a stale policy would score alike)."""
    from actors.character.features import observation_dim
    from actors.envs.imitation_env import EnvConfig

    OBS_DIM = observation_dim(len(EnvConfig().reference_obs_steps))
    from services.training.config import TrainConfig

    def weights(bias_knee: float) -> dict:
        w = {"obs_mean": np.zeros(OBS_DIM, np.float32), "obs_std": np.ones(OBS_DIM, np.float32),
             "obs_clip": np.array(5.0, np.float32), "action_std": np.full(28, 0.1, np.float32),
             "layer0.weight": np.zeros((OBS_DIM, 28), np.float32), "layer0.bias": np.zeros(28, np.float32)}
        w["layer0.bias"][24 + REVOLUTE_NAMES.index("right_knee")] = bias_knee
        return w

    config = TrainConfig(motion="unused", eval_every=100, eval_episodes=2, env=EnvConfig(horizon_s=1.0))
    evaluator = TrainingEvaluator(config)
    evaluator._env = make_eval_env(stand, config.env)  # the standing clip instead of loading `motion`
    assert evaluator.due(0, 99, last=False) is False and evaluator.due(99, 100, last=False) is True
    assert evaluator.due(150, 199, last=True) is True and TrainingEvaluator(TrainConfig(eval_every=0)).due(0, 10**9, True) is False
    straight = evaluator(weights(0.0))
    bent = evaluator(weights(-1.0))
    assert bent["eval/joint_rotation_error_rad"] > 3 * straight["eval/joint_rotation_error_rad"]
    assert set(straight) >= {"eval/normalized_return", "eval/fall_rate", "eval/episode_seconds",
                             "eval/joint_rotation_error_rad", "eval/end_effector_error_m", "eval/distance_ratio"}


def test_blas_threads_are_given_back_after_an_evaluation(stand):
    from threadpoolctl import threadpool_info

    from actors.character.features import observation_dim
    from actors.envs.imitation_env import EnvConfig

    OBS_DIM = observation_dim(len(EnvConfig().reference_obs_steps))
    from services.training.config import TrainConfig

    before = [(p["internal_api"], p["num_threads"]) for p in threadpool_info()]
    config = TrainConfig(motion="unused", eval_episodes=1, env=EnvConfig(horizon_s=0.2))
    evaluator = TrainingEvaluator(config)
    evaluator._env = make_eval_env(stand, config.env)
    evaluator({"obs_mean": np.zeros(OBS_DIM, np.float32), "obs_std": np.ones(OBS_DIM, np.float32),
               "obs_clip": np.array(5.0, np.float32), "action_std": np.ones(28, np.float32),
               "layer0.weight": np.zeros((OBS_DIM, 28), np.float32), "layer0.bias": np.zeros(28, np.float32)})
    assert [(p["internal_api"], p["num_threads"]) for p in threadpool_info()] == before


def test_the_weak_starts_line_names_the_starts_under_half_the_median():
    from services.commands.eval import weak_starts_line

    result = {"start_returns": [[0.0, 0.84], [0.25, 0.02], [0.5, 0.83], [0.75, 0.5]]}
    line = weak_starts_line(result)
    assert line.startswith("1 of 4 starts") and "0.250 (0.02)" in line and "0.750" not in line
    assert weak_starts_line({"start_returns": [[0.0, 0.8], [0.5, 0.7]]}) is None
    assert weak_starts_line({}) is None  # an ONNX-era result without the field
