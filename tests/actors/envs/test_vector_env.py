"""VectorImitationEnv: batched stepping, auto-reset, episode records; local start sources."""
import mujoco
import numpy as np
import pytest

from actors.character.humanoid3d import Humanoid
from actors.envs.imitation_env import EnvConfig
from actors.envs.initial_states import BufferedStarts, InitialStates, ReferenceStarts
from actors.character.state import StateLayout
from actors.envs.vector_env import VectorImitationEnv

HORIZON_S = 0.3  # 9 control steps per looped episode
HORIZON_STEPS = 9
GAMMA = 0.9


@pytest.fixture(scope="module")
def walk():
    pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")
    from actors.motion.formats.io import load_motion

    return load_motion("deepmimic:walk")


def replay_episodes(venv, steps, rng):
    """Step with random actions and rebuild each finished episode from the step outputs."""
    running = [[] for _ in range(venv.num_envs)]
    finished = []  # (env, rewards, fell) in the order the vector env records them
    for _ in range(steps):
        before = venv.obs.copy()
        obs, rewards, terminated, truncated, final_obs = venv.step(rng.uniform(-1, 1, (venv.num_envs, venv.action_dim)))
        assert obs.shape == final_obs.shape == (venv.num_envs, venv.obs_dim) and rewards.shape == (venv.num_envs,)
        assert np.isfinite(obs).all() and np.isfinite(final_obs).all()
        for i in range(venv.num_envs):
            running[i].append(float(rewards[i]))
            if terminated[i] or truncated[i]:
                finished.append((i, running[i], bool(terminated[i])))
                running[i] = []
                assert not np.array_equal(obs[i], final_obs[i]), "a reset env starts a new episode"
            else:
                np.testing.assert_array_equal(obs[i], final_obs[i])
                assert not np.array_equal(obs[i], before[i])
    return finished, running


def test_reference_starts_auto_reset_and_episode_records(walk):
    config = EnvConfig(horizon_s=HORIZON_S)
    starts = BufferedStarts(ReferenceStarts("rsi", np.random.default_rng(0)), batch=4)
    venv = VectorImitationEnv(walk, config, num_envs=3, starts=starts, seed=11, gamma=GAMMA)
    obs = venv.reset()
    assert obs.shape == (3, 211) and obs.dtype == np.float32 and np.isfinite(obs).all()
    assert venv.action_dim == 28 and venv.state_dim == venv.envs[0].state_dim  # exp-map actions: 8 x 3 + 4
    assert len({round(float(p), 6) for p in obs[:, -1]}) == 3, "three different RSI phases"

    finished, running = replay_episodes(venv, 25, np.random.default_rng(1))
    log = venv.episodes.drain()
    n = len(finished)
    assert n >= 6  # every env ran at least two 9-step episodes
    assert all(len(log[k]) == n for k in ("returns", "normalized_returns", "discounted_returns", "lengths", "fell", "components"))
    assert log["initial_states"].shape == (n, venv.state_dim)
    max_reward = venv.envs[0].max_reward
    for k, (env_index, rewards, fell) in enumerate(finished):
        assert log["lengths"][k] == len(rewards) and log["fell"][k] == fell
        assert log["returns"][k] == pytest.approx(sum(rewards), rel=1e-5)
        assert log["discounted_returns"][k] == pytest.approx(sum(r * GAMMA**t for t, r in enumerate(rewards)), rel=1e-5)
        # Normalised by the most the episode could have earned: max reward on every step to the horizon.
        assert log["normalized_returns"][k] == pytest.approx(sum(rewards) / (max_reward * HORIZON_STEPS), rel=1e-5)
        assert 0.0 <= log["normalized_returns"][k] <= 1.0
        assert len(rewards) == HORIZON_STEPS if not fell else len(rewards) <= HORIZON_STEPS
        assert log["components"][k] == -1
    assert sum(log["lengths"]) + sum(len(r) for r in running) == 25 * 3
    assert len(venv.episodes.drain()["returns"]) == 0, "drain empties the log"


class UpsideDownStarts:
    """A local stand-in for the ASI server: full initial states, one component each."""

    def __init__(self, humanoid):
        data = mujoco.MjData(humanoid.model)  # the standing pose...
        data.qpos[2] = 1.0
        data.qpos[3:7] = [0.0, 1.0, 0.0, 0.0]  # ...turned head down
        self.state = StateLayout(humanoid).state_vector(data.qpos, data.qvel)

    def __call__(self, count):
        states = np.tile(self.state, (count, 1))
        states[:, 1:5] *= 2.0  # unnormalised root quaternion: the env normalises it
        return InitialStates(np.full(count, 0.25), np.arange(count, dtype=np.int64) % 5, states)


def test_state_starts_fall_and_record_their_initial_states(walk):
    config = EnvConfig(horizon_s=2.0, state_space="qpos")  # UpsideDownStarts hands out qpos[2:] + qvel vectors
    source = UpsideDownStarts(Humanoid(config.physics))
    venv = VectorImitationEnv(walk, config, num_envs=3, starts=BufferedStarts(source, batch=2), seed=0)
    venv.reset()
    for env in venv.envs:
        assert env.phase == pytest.approx(0.25, abs=1 / (30 * walk.duration))
    finished, _ = replay_episodes(venv, 30, np.random.default_rng(2))
    log = venv.episodes.drain()
    assert len(finished) >= 3 and log["fell"].all(), "head-first starts end in falls"
    assert all(rewards[-1] == 0.0 for _, rewards, _ in finished), "the step that ends in a fall earns nothing"
    assert (log["lengths"] < 2.0 * 30).all()
    assert (log["normalized_returns"] < 0.5).all()
    np.testing.assert_allclose(log["initial_states"], np.tile(source.state, (len(finished), 1)), atol=1e-6)
    assert set(log["components"]) <= {0, 1} and len(set(log["components"])) == 2


def test_buffered_starts_draws_batches():
    calls = []

    def source(count):
        calls.append(count)
        first = sum(calls[:-1])
        return InitialStates(np.arange(first, first + count) / 100.0, np.arange(first, first + count))

    starts = BufferedStarts(source, batch=4)
    taken = [starts.take() for _ in range(10)]
    assert calls == [4, 4, 4]
    assert [t[1] for t in taken] == list(range(10))
    assert [t[0] for t in taken] == pytest.approx([i / 100.0 for i in range(10)])
    assert all(t[2] is None for t in taken)


def test_reference_starts():
    rng = np.random.default_rng(3)
    fsi = ReferenceStarts("fsi", rng)(5)
    assert len(fsi) == 5 and (fsi.phases == 0).all() and (fsi.components == -1).all() and fsi.states is None
    rsi = ReferenceStarts("rsi", rng)(200)
    assert ((rsi.phases >= 0) & (rsi.phases < 1)).all() and rsi.phases.std() > 0.2
    with pytest.raises(ValueError, match="fsi or rsi"):
        ReferenceStarts("asi", rng)
