"""The distillation dataset: chunk/manifest round trip, windows, and the recorder on a tiny expert run."""
from __future__ import annotations

import json

import numpy as np
import pytest

from learner.errors import SfvError
from services.motor.dataset import FIELDS, chunk_name, load_dataset, read_chunk, read_manifest, write_chunk, write_manifest
from services.motor.sequences import WindowSampler, window_starts
from tests.services.training.test_evaluate_strict import stand_motion


def random_rows(rng: np.random.Generator, rows: int, clip: int, episode_lengths: list[int]) -> dict:
    arrays = {name: rng.standard_normal((rows, *shape)).astype(dtype) if dtype == "float32" else np.zeros((rows, *shape), dtype)
              for name, (dtype, shape) in FIELDS.items()}
    arrays["clip"][:] = clip
    arrays["episode"][:] = np.repeat(np.arange(len(episode_lengths)), episode_lengths)
    arrays["step"][:] = np.concatenate([np.arange(n) for n in episode_lengths])
    return arrays


def test_chunks_and_manifest_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    parts = [random_rows(rng, 7, 0, [3, 4]), random_rows(rng, 5, 1, [5]), random_rows(rng, 6, 1, [2, 4])]
    chunks = []
    for index, arrays in enumerate(parts):
        write_chunk(tmp_path / chunk_name(index), arrays)
        chunks.append({"file": chunk_name(index), "clip": int(arrays["clip"][0]), "steps": len(arrays["clip"]), "episodes": 2})
    manifest = write_manifest(tmp_path, ["walk", "kick"], chunks, {"note": 1})
    assert read_manifest(tmp_path) == manifest
    assert manifest["steps"] == 18 and manifest["steps_per_clip"] == {"walk": 7, "kick": 11}
    assert manifest["bytes"] == sum((tmp_path / c["file"]).stat().st_size for c in chunks)
    data, _ = load_dataset(tmp_path)
    for name in FIELDS:
        assert np.array_equal(data[name], np.concatenate([p[name] for p in parts]))
    without, _ = load_dataset(tmp_path, exclude_clips=("kick",))
    assert np.array_equal(without["future"], parts[0]["future"])
    with pytest.raises(SfvError, match="clips \\['run'\\] are not in the dataset"):
        load_dataset(tmp_path, exclude_clips=("run",))


def test_faulty_chunks_and_manifests_are_one_clear_error(tmp_path):
    arrays = random_rows(np.random.default_rng(1), 4, 0, [4])
    arrays["future"] = arrays["future"][:, :10]
    with pytest.raises(SfvError, match="field future"):
        write_chunk(tmp_path / "x.npz", arrays)
    (tmp_path / "y.npz").write_bytes(b"not a zip")
    with pytest.raises(SfvError, match="y.npz: unreadable dataset chunk"):
        read_chunk(tmp_path / "y.npz")
    with pytest.raises(SfvError, match="not a motor dataset"):
        read_manifest(tmp_path)
    (tmp_path / "manifest.json").write_text(json.dumps({"format": "other"}))
    with pytest.raises(SfvError, match="manifest.json: not a sfv-motor-dataset"):
        read_manifest(tmp_path)


def test_windows_never_cross_episodes_and_validation_takes_whole_episodes():
    clip = np.array([0] * 9 + [1] * 6)
    episode = np.array([0, 0, 0, 0, 1, 1, 1, 1, 1, 0, 0, 0, 1, 1, 1])
    assert list(window_starts(clip.astype(np.int64) * 100 + episode, 3)) == [0, 1, 4, 5, 6, 9, 12]
    sampler = WindowSampler(np.repeat(np.arange(2), 500), np.repeat(np.arange(100), 10), 4, 0.2, seed=0)
    rows = sampler.sample(np.random.default_rng(0), 256)
    keys = np.repeat(np.arange(100), 10)
    assert rows.shape == (256, 4) and np.all(keys[rows] == keys[rows[:, :1]]) and np.all(np.diff(rows, axis=1) == 1)
    train, validation = set(keys[sampler.train_starts]), set(keys[sampler.validation_starts])
    assert validation and not train & validation
    with pytest.raises(SfvError, match="consecutive steps"):
        WindowSampler(np.zeros(3, int), np.arange(3), 2, 0.0, 0)


@pytest.fixture(scope="module")
def random_expert(tmp_path_factory):
    """A run directory on a standing clip with an untrained (random) policy: a tiny 'expert'."""
    import torch

    from tests.stand_run import write_stand_run

    def far_from_zero(policy):  # a random policy whose mean actions are far from zero
        policy.mean_net[-1].weight.mul_(30.0)

    torch.manual_seed(0)
    return write_stand_run(tmp_path_factory.mktemp("expert"), stand_motion(), far_from_zero, hidden=(16, 8))


def test_recorder_rolls_a_tiny_expert_out_with_noise(random_expert, tmp_path):
    from actors.character.actions import ActionMapper
    from services.motor.recorder import RecordConfig, record_clip

    config = RecordConfig(steps_per_clip=130, episode_steps=40, chunk_steps=60, noise_std=0.1)
    chunks = record_clip(str(random_expert.parent), random_expert.name, 3, str(tmp_path), config)
    assert sum(c["steps"] for c in chunks) == 130 and len(chunks) >= 2
    data = [read_chunk(tmp_path / c["file"]) for c in chunks]
    rows = {name: np.concatenate([d[name] for d in data]) for name in FIELDS}
    assert np.all(rows["clip"] == 3)
    for episode in np.unique(rows["episode"]):  # consecutive steps, in order, one row per step
        steps = rows["step"][rows["episode"] == episode]
        assert np.array_equal(steps, np.arange(len(steps))) and len(steps) <= 40
        table_rows = rows["row"][rows["episode"] == episode]
        assert np.all(np.diff(table_rows) == 1)
    limits = ActionMapper()
    for name in ("mean_targets", "applied_targets"):
        assert np.all(rows[name] >= limits.lower - 1e-6) and np.all(rows[name] <= limits.upper + 1e-6)
    gap = np.abs(rows["applied_targets"] - rows["mean_targets"])
    # noise 0.1 on residual actions (0.5 rad each): the applied targets differ by ~0.04 rad, except where clipped
    assert 0.01 < np.median(gap) < 0.1
    assert np.isfinite(rows["future"]).all() and np.abs(rows["proprio"][:, 0] - 0.0).min() > 0.3  # a standing root height
    noiseless = record_clip(str(random_expert.parent), random_expert.name, 0, str(tmp_path / "quiet"), RecordConfig(steps_per_clip=20, episode_steps=20, noise_std=0.0))
    quiet = read_chunk(tmp_path / "quiet" / noiseless[0]["file"])
    assert np.allclose(quiet["applied_targets"], quiet["mean_targets"], atol=1e-5)


def test_future_features_of_a_character_on_its_reference(shared_humanoid):
    """On the reference itself (a standing clip) the pose differences are zero and the future roots sit at the root."""
    from actors.envs.tasks.future_reference import POSE_WIDTH, STEP_WIDTH, FutureReference
    from actors.envs.imitation_env import EnvConfig, ImitationEnv
    from actors.envs.tasks.proprioception import PROPRIO_DIM, proprioception_from_observation

    env = ImitationEnv(stand_motion(), EnvConfig(reference_obs_steps=(), horizon_s=1.0), shared_humanoid)
    obs, _ = env.reset(options={"init": "fsi"})
    future = FutureReference(env.track, env.humanoid)
    proprio, features = np.zeros(PROPRIO_DIM), np.zeros(future.width)
    future(env.data, env.row, env.root_sync.offset, proprio, features)
    assert proprio == pytest.approx(proprioception_from_observation(obs).astype(np.float64), abs=1e-5)
    steps = features.reshape(5, STEP_WIDTH)
    assert np.abs(steps[:, :POSE_WIDTH]).max() < 1e-6
    assert np.abs(steps[:, POSE_WIDTH:POSE_WIDTH + 3]).max() < 1e-6 and steps[:, POSE_WIDTH + 3] == pytest.approx(np.ones(5))
    env.data.qpos[0] += 0.5  # the character half a metre ahead (along world x) of its reference
    from actors.character.features import update_kinematics

    update_kinematics(env.model, env.data)
    future(env.data, env.row, env.root_sync.offset, proprio, features)
    relative = features.reshape(5, STEP_WIDTH)[:, POSE_WIDTH:POSE_WIDTH + 2]
    assert np.linalg.norm(relative, axis=1) == pytest.approx(np.full(5, 0.5), abs=1e-6)
    assert np.abs(features.reshape(5, STEP_WIDTH)[:, :POSE_WIDTH]).max() < 1e-6  # egocentric pose unchanged
