"""The reference's horizontal root re-synchronised to the character's at each new cycle of a
looped clip (actors/envs/root_sync.py, DeepMimic's SyncKinCharNewCycle).

Each step starts from the reference's own state moved 0.3 m / -0.1 m on the ground (from
step 5 on), so the character stays upright but lags the reference; the root term is then
recomputed here from qpos / qvel and the reference table, against the reference shifted (or
not) as DeepMimic would.
"""
import numpy as np
import pytest

from actors.character.features import update_kinematics
from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.envs.initial_states import BufferedStarts, ReferenceStarts
from actors.envs.vector_env import VectorImitationEnv
from tests.conftest import load_clip

SHIFT = np.array([0.3, -0.1])  # how far the character lags the reference, metres
LAG_FROM = 5  # from this step on


@pytest.fixture(scope="module")
def humanoid(shared_humanoid):
    return shared_humanoid


@pytest.fixture(scope="module")
def clips():
    return {name: load_clip(name) for name in ("walk", "kick")}


def root_term(data, track, row, offset_xy):
    """DeepMimic's root term: exp(-5 (|dp|^2 + .1 angle^2 + .01 |dv|^2 + .001 |dw|^2)), the
    reference's root moved by offset_xy on the ground."""
    ref_pos = track.qpos[row, :3] + np.append(offset_xy, 0.0)
    dp = data.qpos[:3] - ref_pos
    angle = 2.0 * np.arccos(min(1.0, abs(float(data.qpos[3:7] @ track.qpos[row, 3:7]))))
    dv = data.qvel[:3] - track.reference_qvel[row, :3]
    dw = data.qvel[3:6] - track.reference_qvel[row, 3:6]
    return float(np.exp(-5.0 * (dp @ dp + 0.1 * angle**2 + 0.01 * dv @ dv + 0.001 * dw @ dw)))


def guided_step(env, lag):
    """One zero-action step from the reference's state at the current row, moved by `lag` on
    the ground: the character stays upright and on the clip's path, `lag` behind it."""
    row = env.row
    env.data.qpos[:] = env.track.qpos[row]
    env.data.qpos[:2] += lag
    env.data.qvel[:] = env.track.reference_qvel[row]
    update_kinematics(env.model, env.data)
    return env.step(np.zeros(env.action_space.shape))


def play(env, steps, lag_from=LAG_FROM):
    """FSI, then guided steps, lagging SHIFT from `lag_from` on; per step: (row, reward,
    terms, root xy, the root term against the table's unshifted reference)."""
    env.reset(seed=0, options={"init": "fsi"})
    out = []
    for step in range(steps):
        _, reward, terminated, truncated, _ = guided_step(env, SHIFT if step >= lag_from else np.zeros(2))
        assert not terminated
        out.append((env.row, reward, env.reward_terms.copy(), env.data.qpos[:2].copy(),
                    root_term(env.data, env.track, env.row, np.zeros(2))))
        if truncated:
            break
    return out


def test_after_a_cycle_boundary_the_reference_root_is_the_characters(clips, humanoid):
    env = ImitationEnv(clips["walk"], EnvConfig(horizon_s=2.0), humanoid)
    cycle = env.track.start_steps
    env.reset(seed=0, options={"init": "fsi"})
    offset = np.zeros(2)
    for step in range(cycle + 8):
        _, _, terminated, _, _ = guided_step(env, SHIFT if step >= LAG_FROM else np.zeros(2))
        assert not terminated
        row = env.row
        if row == cycle:  # a new cycle starts: the reference moves under the character
            offset = env.data.qpos[:2] - env.track.qpos[row, :2]
            np.testing.assert_allclose(offset, SHIFT, atol=0.02)  # the lag, plus one step's physics
            np.testing.assert_allclose(env.root_sync.offset[0], offset, atol=1e-12)
        expected = root_term(env.data, env.track, row, offset)
        assert env.reward_terms[3] == pytest.approx(expected, rel=1e-9), row
        if LAG_FROM <= step and row < cycle:
            assert env.reward_terms[3] < 0.65  # 0.32 m off: exp(-5 * 0.1) = 0.61 at best
        if row >= cycle:
            assert env.reward_terms[3] > 0.9
    assert row > cycle


def test_sync_moves_only_the_reward_not_the_physics(clips, humanoid):
    synced = play(ImitationEnv(clips["walk"], EnvConfig(horizon_s=2.0), humanoid), 48)
    plain = play(ImitationEnv(clips["walk"], EnvConfig(horizon_s=2.0, sync_root_per_cycle=False), humanoid), 48)
    cycle = int(round(clips["walk"].duration * 30))  # a cycle of the walk: 38 control steps
    for (row, r_sync, t_sync, xy_sync, _), (_, r_plain, t_plain, xy_plain, unshifted) in zip(synced, plain):
        np.testing.assert_array_equal(xy_sync, xy_plain)  # same trajectory
        np.testing.assert_allclose(t_sync[[0, 1, 2, 4]], t_plain[[0, 1, 2, 4]], rtol=1e-12)  # pose, vel, ee, com
        assert t_plain[3] == pytest.approx(unshifted, rel=1e-9)  # without sync: the table's root
        if row < cycle:
            assert t_sync[3] == pytest.approx(t_plain[3], rel=1e-12)
        else:
            assert t_sync[3] > t_plain[3] + 0.25 and r_sync > r_plain + 0.05


def test_no_sync_for_clips_that_do_not_loop(clips, humanoid):
    # The reference's own velocities at its flight rows: `root_term` reads the table's qvel, which
    # ballistic start states change there, while the reward keeps the clip's.
    env = ImitationEnv(clips["kick"], EnvConfig(horizon_s=2.0, flight_starts="reference"), humanoid)
    assert not clips["kick"].loop
    steps = play(env, 100)
    assert steps[-1][0] == env.track.start_steps  # played to the clip's end, through row % cycle == 0
    for row, _, terms, _, unshifted in steps:
        assert terms[3] == pytest.approx(unshifted, rel=1e-9), row
    assert steps[-1][2][3] < 0.65


def test_a_new_episode_starts_without_offset(clips, humanoid):
    env = ImitationEnv(clips["walk"], EnvConfig(horizon_s=2.0), humanoid)
    play(env, 45)
    np.testing.assert_allclose(env.root_sync.offset[0], SHIFT, atol=0.02)
    for options in ({"init": "fsi"}, {"phase": 0.5}):
        env.reset(seed=0, options=options)
        env.step(np.zeros(env.action_space.shape))
        assert env.reward_terms[3] == pytest.approx(root_term(env.data, env.track, env.row, np.zeros(2)), rel=1e-9)


def test_vector_env_syncs_each_env_like_the_single_env(clips, humanoid):
    config = EnvConfig(horizon_s=2.0)
    starts = BufferedStarts(ReferenceStarts("fsi", np.random.default_rng(0)), batch=2)
    venv = VectorImitationEnv(clips["walk"], config, num_envs=2, starts=starts, seed=0)
    venv.reset()
    single = play(ImitationEnv(clips["walk"], config, humanoid), 45)
    for step in range(45):
        for i, env in enumerate(venv.envs):  # env 0 lags like the single env, env 1 stays on the track
            row = env.row
            env.data.qpos[:] = env.track.qpos[row]
            env.data.qpos[:2] += SHIFT if (i == 0 and step >= LAG_FROM) else 0.0
            env.data.qvel[:] = env.track.reference_qvel[row]
            update_kinematics(env.model, env.data)
        _, rewards, terminated, truncated, _ = venv.step(np.zeros((2, venv.action_dim)))
        assert not terminated.any() and not truncated.any()
        assert rewards[0] == pytest.approx(single[step][1], rel=1e-9), step
    assert venv.envs[0].row == 45 > venv.track.start_steps
    np.testing.assert_allclose(venv.root_sync.offset[0], SHIFT, atol=0.02)
    np.testing.assert_allclose(venv.root_sync.offset[1], 0.0, atol=0.02)


def test_the_papers_com_position_term_follows_the_synced_reference(clips, humanoid):
    from actors.envs.modes.sfv.config import SfvConfig
    from actors.envs.modes.sfv.reward import RewardConfig

    env = ImitationEnv(clips["walk"], EnvConfig(horizon_s=2.0, sfv=SfvConfig(reward=RewardConfig.sfv_paper())), humanoid)
    cycle = env.track.start_steps
    row, _, terms, _, _ = play(env, cycle + 5)[-1]
    offset = np.append(env.root_sync.offset[0], 0.0)
    np.testing.assert_allclose(offset[:2], SHIFT, atol=0.02)
    d = env.data.subtree_com[1] - (env.track.features.com[row] + offset)
    assert terms[4] == pytest.approx(np.exp(-10.0 * d @ d), rel=1e-9)
    assert terms[4] > 0.9  # against the table's COM it would be exp(-10 * 0.1) at best
