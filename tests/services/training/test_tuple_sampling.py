"""Adaptive tuple sampling (paper 002 §5.2, eq. 13): the draw, the windows, the masked PPO
update and one training iteration with it on."""
import json

import numpy as np
import pytest

from learner.config import PPOConfig
from learner.errors import BatchFormatError
from learner.ppo import PPOLearner
from learner.tuple_sampling import adaptive_tuple_mask, coverage_stats
from tests.learner_helpers import behaviour_rollout


def random_episodes(rng, steps, envs, end_probability):
    """(frames, ends) of envs whose episodes end at random and restart at random frames."""
    ends = rng.random((steps, envs)) < end_probability
    frames = np.empty((steps, envs), np.int32)
    frame = rng.integers(0, 50, envs)
    for t in range(steps):
        frames[t] = frame
        frame = np.where(ends[t], rng.integers(0, 50, envs), frame + 1)
    return frames, ends


def segments_of(ends):
    """(env, first, last) of each episode segment, the block's end cutting the running ones."""
    steps, envs = ends.shape
    out = []
    for i in range(envs):
        first = 0
        for t in range(steps):
            if ends[t, i] or t == steps - 1:
                out.append((i, first, t))
                first = t + 1
    return out


def test_start_frames_are_drawn_with_probability_inverse_to_tuples_already_there():
    # K = 4. Env 0's first episode (frames 0-3, ends at step 3) is used whole: n = 1 on frames 0-3.
    # Env 1's episode (frames 0-9, ends at step 9) then allows starts at frames 0-6 with
    # P ~ 1/(n + 1) = 1/2, 1/2, 1/2, 1/2, 1, 1, 1. Env 0's second episode lies at frames 100+.
    frames = np.zeros((10, 2), np.int32)
    frames[:4, 0] = np.arange(4)
    frames[4:, 0] = 100 + np.arange(6)
    frames[:, 1] = np.arange(10)
    ends = np.zeros((10, 2), bool)
    ends[3, 0] = ends[9, 1] = True
    rng = np.random.default_rng(0)
    draws = 20_000
    starts = np.array([np.argmax(adaptive_tuple_mask(frames, ends, rng, 4)[:, 1]) for _ in range(draws)])
    observed = np.bincount(starts, minlength=7) / draws
    expected = np.array([0.5, 0.5, 0.5, 0.5, 1, 1, 1]) / 5
    assert observed.shape == (7,)
    np.testing.assert_allclose(observed, expected, atol=0.012)  # ~4 standard errors


def test_each_episode_segment_gives_k_consecutive_tuples_or_all_of_a_short_one():
    rng = np.random.default_rng(1)
    frames, ends = random_episodes(rng, steps=200, envs=8, end_probability=0.02)
    mask = adaptive_tuple_mask(frames, ends, np.random.default_rng(2), 32)
    segments = segments_of(ends)
    assert any(last - first + 1 < 32 for _, first, last in segments)  # the case is exercised
    assert any(last - first + 1 > 32 for _, first, last in segments)
    for env, first, last in segments:
        chosen = np.flatnonzero(mask[first:last + 1, env])
        assert len(chosen) == min(32, last - first + 1)
        assert np.all(np.diff(chosen) == 1)  # consecutive
    assert mask.sum() == sum(min(32, last - first + 1) for _, first, last in segments)


def test_windows_go_where_fewer_tuples_are():
    # Many short episodes fill frames 0-31; long episodes reaching frame 95 should then take
    # their windows mostly beyond frame 31.
    steps, envs = 96, 40
    frames = np.tile(np.arange(steps, dtype=np.int32)[:, None], (1, envs))
    ends = np.zeros((steps, envs), bool)
    ends[31, :30] = True  # 30 episodes end at frame 31 (used whole); their envs restart at 32
    frames[32:, :30] = 200 + np.arange(steps - 32)[:, None]  # out of the way
    mask = adaptive_tuple_mask(frames, ends, np.random.default_rng(3), 32)
    long_frames = frames[:, 30:][mask[:, 30:]]
    assert (long_frames >= 32).mean() > 0.8  # uniform windows over starts 0-64 would give ~0.6


def test_bad_inputs_are_refused():
    with pytest.raises(ValueError, match="equal"):
        adaptive_tuple_mask(np.zeros((4, 2), int), np.zeros((4, 3), bool), np.random.default_rng(0))
    with pytest.raises(ValueError, match=">= 0"):
        adaptive_tuple_mask(-np.ones((4, 2), int), np.zeros((4, 2), bool), np.random.default_rng(0))


def test_coverage_stats_of_an_even_and_an_uneven_selection():
    frames = np.repeat(np.arange(4), 3).reshape(-1, 1)  # 3 tuples at each of frames 0-3
    even = coverage_stats(frames)
    assert even["tuple_sampling/used_fraction"] == 1.0 and even["tuple_sampling/frame_entropy"] == pytest.approx(1.0)
    uneven = coverage_stats(frames, (frames < 1) | (frames == 3) & (np.arange(12).reshape(-1, 1) % 3 == 0))
    assert uneven["tuple_sampling/used_fraction"] == pytest.approx(4 / 12)
    assert (uneven["tuple_sampling/frame_count_min"], uneven["tuple_sampling/frame_count_max"]) == (0, 3)
    assert uneven["tuple_sampling/frame_entropy"] < 0.6


# ------------------------------------------------------------------- the masked PPO update
def small_learner():
    config = PPOConfig(policy_hidden=(16,), value_hidden=(16,), minibatch_size=32, update_epochs=2, target_kl=None, seed=0)
    return PPOLearner(3, 2, config)


def episode_batch(seed=0, steps=48, envs=4):
    rng = np.random.default_rng(seed)
    batch = behaviour_rollout(small_learner(), rng, steps, envs, 3)
    batch["next_obs"] = np.concatenate([batch["obs"][1:], rng.normal(size=(1, envs, 3)).astype(np.float32)])
    batch["rewards"] = rng.uniform(0, 1, (steps, envs)).astype(np.float32)
    batch["terminated"] = np.zeros((steps, envs), bool)
    batch["truncated"] = np.zeros((steps, envs), bool)
    mask = np.zeros((steps, envs), bool)
    mask[8:40] = True  # one window of 32 per env, inside one episode
    return batch, mask


def updated_weights(batch):
    learner = small_learner()
    learner.update(batch)
    return learner.policy_weights()


def same(a, b):
    return all(np.array_equal(a[k], b[k]) for k in a)


def test_masked_update_trains_on_the_window_with_targets_from_the_whole_episode():
    batch, mask = episode_batch()
    masked = updated_weights({**batch, "update_mask": mask})
    assert same(masked, updated_weights({**batch, "update_mask": np.ones_like(mask)})) is False
    assert same(updated_weights(batch), updated_weights({**batch, "update_mask": np.ones_like(mask)}))
    # Actions outside the window are not trained on: changing them changes nothing ...
    other_actions = batch["actions"].copy()
    other_actions[40:] += 0.5
    other_actions[:8] -= 0.5
    assert same(masked, updated_weights({**batch, "actions": other_actions, "update_mask": mask}))
    # ... but rewards after the window still reach the window's advantages and value targets.
    later_rewards = batch["rewards"].copy()
    later_rewards[40:] = 0.0
    assert not same(masked, updated_weights({**batch, "rewards": later_rewards, "update_mask": mask}))


def test_a_mask_of_the_wrong_shape_or_selecting_nothing_is_refused():
    batch, mask = episode_batch()
    with pytest.raises(BatchFormatError, match="update_mask"):
        small_learner().update({**batch, "update_mask": mask[:-1]})
    with pytest.raises(BatchFormatError, match="selects no tuple"):
        small_learner().update({**batch, "update_mask": np.zeros_like(mask)})


# -------------------------------------------------------------------- one training iteration
def test_training_with_adaptive_sampling_logs_its_coverage(tmp_path):
    from actors.envs.imitation_env import EnvConfig
    from services.training.config import TrainConfig
    from services.training.driver import Trainer

    out = tmp_path / "run"
    # No falls and no curriculum: every env's 64-step block is one segment of a 20 s episode,
    # of which 32 tuples are used.
    config = TrainConfig(out=str(out), workers=1, envs_per_worker=4, init="rsi", samples=256, runner="in_process",
                         checkpoint_every=1, plot_every=0, eval_every=0, curriculum_start_s=0.0, torch_threads=1,
                         env=EnvConfig(early_termination=False))
    config.ppo.batch_size, config.ppo.minibatch_size = 256, 64
    config.ppo.policy_hidden = config.ppo.value_hidden = (32,)
    config.ppo.target_kl = None  # every minibatch runs: the gradient steps count the tuples used
    config.ppo.tuple_sampling = "adaptive"
    Trainer(config, progress=False).run()
    row = json.loads((out / "metrics.jsonl").read_text().splitlines()[-1])
    assert row["tuple_sampling/used_fraction"] == pytest.approx(0.5)
    assert sum(row["tuple_sampling/used_per_frame_bin"]) == 128
    assert sum(row["tuple_sampling/collected_per_frame_bin"]) == 256
    assert 0.0 < row["tuple_sampling/frame_entropy"] <= 1.0
    assert row["charts/gradient_steps"] == 2.0  # 128 used tuples in minibatches of 64


# ------------------------------------------------------------------- the benchmark's read-back
def test_the_benchmark_reads_samples_to_nr_and_coverage_from_metrics(tmp_path):
    from tests.bench_scripts import load_bench_script

    bench = load_bench_script("adaptive_sampling")
    rng = np.random.default_rng(0)
    rows, used_total = [], np.zeros(4, int)
    for i, nr in enumerate([0.04, None, 0.07, None, 0.12]):
        used = rng.integers(0, 50, 4)
        used_total += used
        row = {"samples": 1000 * (i + 1), "samples_per_s": 500.0, "sampling_samples_per_s": 1000.0,
               "tuple_sampling/used_per_frame_bin": used.tolist(), "tuple_sampling/collected_per_frame_bin": [50] * 4,
               "tuple_sampling/frame_entropy": 0.9, "tuple_sampling/frame_count_min": 1.0, "tuple_sampling/frame_count_max": 9.0}
        if nr is not None:
            row.update({"eval/normalized_return": nr, "eval/fall_rate": 1.0, "eval/seconds": 0.5})
        rows.append(row)
    (tmp_path / "metrics.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    result = bench.arm_result(tmp_path, thresholds=(0.05, 0.1, 0.5))
    assert result["samples_to_nr"] == {"0.05": 3000, "0.1": 5000, "0.5": None}
    assert result["train_s_to_nr"]["0.05"] == pytest.approx(6.0)  # three iterations of 1000 samples at 500/s
    assert result["update_s"] == pytest.approx(5 * (2.0 - 1.0)) and result["eval_s"] == pytest.approx(1.5)
    assert result["frame_bins"]["used"] == used_total.tolist()
    assert result["tuples_used_fraction"] == pytest.approx(used_total.sum() / 1000)
