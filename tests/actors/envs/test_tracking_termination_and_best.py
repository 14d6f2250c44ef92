"""Early termination on tracking deviation (`EnvConfig.sfv.tracking_termination_m`) and the best
checkpoint (`best.pt`, what eval / render / export read by default)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from actors.character.features import RewardFeatures
from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.envs.modes.sfv.config import SfvConfig
from actors.envs.initial_states import BufferedStarts, ReferenceStarts
from actors.envs.modes.sfv.tracking_termination import TrackingTermination
from actors.character.skeleton import LINK_NAMES
from actors.envs.vector_env import OTHER_END, VectorImitationEnv
from learner.checkpoint import load_checkpoint
from learner.errors import SfvError
from services.training.config import TrainConfig
from services.training.driver import Trainer, fall_cause_shares
from services.training.evaluation import evaluate_policy
from services.training.run_dir import BEST_CHECKPOINT, METRICS_FILE, load_run, run_checkpoint


def features_with(ee_shift=(0.0, 0.0, 0.0), root_shift=(0.0, 0.0, 0.0), nv=34) -> tuple[RewardFeatures, RewardFeatures]:
    rng = np.random.default_rng(3)
    ref = RewardFeatures(rng.normal(size=(1, RewardFeatures.zeros(nv).values.shape[1])))
    sim = RewardFeatures(ref.values.copy())
    sim.end_effectors[0, 2] += ee_shift
    sim.root_pos[0] += root_shift
    return sim, ref


def test_deviation_is_the_largest_end_effector_or_root_distance():
    rule = TrackingTermination(0.4)
    sim, ref = features_with(ee_shift=(0.3, 0.0, 0.4))
    assert rule.deviation(sim, ref)[0] == pytest.approx(0.5)
    assert rule(sim, ref)[0]
    sim, ref = features_with(root_shift=(0.0, -0.35, 0.0))
    assert rule.deviation(sim, ref)[0] == pytest.approx(0.35)
    assert not rule(sim, ref)[0]
    off = TrackingTermination(0.0)
    sim, ref = features_with(root_shift=(5.0, 0.0, 0.0))
    assert not off.active and not off(sim, ref)[0]
    with pytest.raises(ValueError, match=">= 0"):
        TrackingTermination(-1.0)


def pushed_episode(env: ImitationEnv, shift_m: float) -> tuple[float, bool]:
    env.reset(seed=0, options={"init": "rsi", "phase": 0.2})
    env.data.qpos[0] += shift_m  # the whole body moved sideways: every position off by shift_m
    _, reward, terminated, _, _ = env.step(np.zeros(env.action_space.shape))
    return reward, terminated


def test_a_character_far_from_the_reference_ends_the_episode_as_a_fall(walk_clip, shared_humanoid):
    env = ImitationEnv(walk_clip, EnvConfig(sfv=SfvConfig(tracking_termination_m=0.5)), shared_humanoid)
    assert pushed_episode(env, 0.8) == (0.0, True)
    reward, terminated = pushed_episode(env, 0.2)
    assert not terminated and reward > 0.3
    plain = ImitationEnv(walk_clip, EnvConfig(), shared_humanoid)  # off by default
    assert not pushed_episode(plain, 0.8)[1]


def test_the_vector_env_applies_it_per_env(walk_clip):
    starts = BufferedStarts(ReferenceStarts("rsi", np.random.default_rng(1)), batch=4)
    venv = VectorImitationEnv(walk_clip, EnvConfig(sfv=SfvConfig(tracking_termination_m=0.5)), num_envs=2, starts=starts, seed=1)
    venv.reset()
    venv.envs[1].data.qpos[0] += 0.8
    _, rewards, terminated, _, _ = venv.step(np.zeros((2, venv.action_dim)))
    assert list(terminated) == [False, True]
    assert rewards[1] == 0.0 and rewards[0] > 0.3
    episodes = venv.episodes.drain()
    assert episodes["fell"].tolist() == [True]
    assert episodes["fall_causes"].tolist() == [OTHER_END]  # no link on the ground: the deviation ended it
    assert fall_cause_shares(episodes["fall_causes"]) == {"falls/other": 1.0}


def test_fall_causes_name_the_links_on_the_ground(walk_clip, shared_humanoid):
    env = ImitationEnv(walk_clip, EnvConfig(), shared_humanoid)
    env.reset(seed=0, options={"init": "rsi", "phase": 0.0})
    env.data.qpos[2] = 0.1  # the pelvis dropped to the floor: legs and more touch
    env.data.qvel[:] = 0.0
    _, _, terminated, _, _ = env.step(np.zeros(28))
    causes = env.fall_detector.touching(env.data)
    touching = {name for bit, name in enumerate(LINK_NAMES) if causes >> bit & 1}
    assert terminated and {"left_knee", "right_knee"} <= touching and not touching & {"right_ankle", "left_ankle"}  # feet are allowed
    shares = fall_cause_shares(np.array([causes, 0, 0, 0]))
    assert shares["falls/left_knee"] == 0.25 and set(shares) == {f"falls/{name}" for name in touching}


class Frozen:
    """A policy whose mean is zero: the PD targets are the reference's."""

    def mean(self, obs):
        return np.zeros((obs.shape[0], 28), np.float32)


def test_evaluation_ignores_it(walk_clip, shared_humanoid):
    strict = ImitationEnv(walk_clip, EnvConfig(sfv=SfvConfig(tracking_termination_m=0.01)), shared_humanoid)
    result = evaluate_policy(Frozen(), strict, episodes=2)
    plain = evaluate_policy(Frozen(), ImitationEnv(walk_clip, EnvConfig(), shared_humanoid), episodes=2)
    assert result["episode_length"] == plain["episode_length"] > 5  # 1 cm would end every episode at once


# -------------------------------------------------------------------------- best.pt
@pytest.fixture(scope="module")
def evaluated_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("best") / "run"
    config = TrainConfig(out=str(out), workers=1, envs_per_worker=4, init="rsi", samples=6 * 512, runner="in_process",
                         torch_threads=1, eval_every=512, eval_episodes=2, plot_every=0, checkpoint_every=1)
    config.ppo.batch_size = config.ppo.minibatch_size = 512
    config.ppo.policy_hidden = config.ppo.value_hidden = (32,)
    config.ppo.policy_lr = 3e-3  # big steps: the evaluations differ from one iteration to the next
    Trainer(config, progress=False).run()
    rows = [json.loads(line) for line in (out / METRICS_FILE).read_text().splitlines()]
    return out, [r for r in rows if "eval/normalized_return" in r]


def test_best_pt_holds_the_best_evaluation(evaluated_run):
    out, evaluations = evaluated_run
    assert len(evaluations) == 6
    scores = [r["eval/normalized_return"] for r in evaluations]
    best = load_checkpoint(out / BEST_CHECKPOINT)
    assert best["eval"]["eval/normalized_return"] == pytest.approx(max(scores))
    assert best["samples"] == evaluations[int(np.argmax(scores))]["samples"]
    improved = [r for r in evaluations if "eval/best_normalized_return" in r]  # marked where best.pt was written
    assert improved[0] is evaluations[0] and improved[-1]["eval/best_normalized_return"] == pytest.approx(max(scores))


def test_runs_are_read_from_best_pt_unless_latest_is_asked(evaluated_run):
    out, _ = evaluated_run
    assert run_checkpoint(out).name == BEST_CHECKPOINT
    assert run_checkpoint(out, "latest").name.startswith("checkpoint_")
    best = load_checkpoint(out / BEST_CHECKPOINT)["policy_weights"]
    _, weights = load_run(out)
    for key, value in best.items():
        np.testing.assert_array_equal(weights[key], value.numpy())
    with pytest.raises(SfvError, match="--checkpoint"):
        run_checkpoint(out, "oldest")


def test_eval_and_export_choose_the_checkpoint(evaluated_run, tmp_path, capsys):
    from services.cli import main

    out, _ = evaluated_run
    assert main(["eval", str(out), "--episodes", "1"]) == 0
    assert json.loads(capsys.readouterr().out)["checkpoint"] == "best.pt"
    assert main(["eval", str(out), "--episodes", "1", "--checkpoint", "latest"]) == 0
    assert json.loads(capsys.readouterr().out)["checkpoint"].startswith("checkpoint_")
    assert main(["export", str(out), "--onnx", str(tmp_path / "p.onnx"), "--checkpoint", "best"]) == 0
    assert json.loads(capsys.readouterr().out)["max_abs_diff_vs_checkpoint"] < 1e-4
