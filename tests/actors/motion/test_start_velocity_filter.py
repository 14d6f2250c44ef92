"""Start states' velocities lose the clip's one-row spikes; steps, the pose and the reward stay."""
from __future__ import annotations

import numpy as np
import pytest

from actors.character.humanoid3d import Humanoid
from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.motion.formats.io import load_motion
from actors.motion.reference_track import ReferenceTrack
from actors.motion.start_velocity_filter import median_start_velocities
from services.training.config import TrainConfig

DT = 1.0 / 30.0


def test_a_spike_goes_a_step_and_a_line_stay():
    spike = np.zeros((20, 2))
    spike[8] = [1.55, -3.0]  # the roll's root rising at 1.55 m/s for one row
    np.testing.assert_array_equal(median_start_velocities(spike, 3, None), np.zeros((20, 2)))
    step = np.where(np.arange(20)[:, None] < 10, -2.4, 0.0) * np.ones((1, 2))  # a landing: falling, then standing
    np.testing.assert_array_equal(median_start_velocities(step, 3, None), step)
    line = np.arange(20, dtype=np.float64)[:, None] * [0.1, -0.2]
    np.testing.assert_allclose(median_start_velocities(line, 5, None)[2:-2], line[2:-2])
    # Two neighbouring spikes are a motion for a 3-row median, jitter for a 5-row one.
    pair = np.zeros((20, 1))
    pair[[8, 9]] = 1.0
    assert median_start_velocities(pair, 3, None)[8, 0] == 1.0 and median_start_velocities(pair, 5, None)[8, 0] == 0.0


def test_a_spike_at_a_clips_first_or_last_row_goes_too():
    # A video whose subject has just appeared: its first frame's velocity is a jump from nowhere.
    qvel = np.zeros((12, 2))
    qvel[0] = [6.7, -2.0]
    qvel[-1] = [-4.0, 1.0]
    np.testing.assert_array_equal(median_start_velocities(qvel, 3, None), np.zeros((12, 2)))
    np.testing.assert_array_equal(median_start_velocities(qvel, 5, None), np.zeros((12, 2)))
    short = np.array([[1.0], [3.0]])  # fewer rows than the window: the median of the whole clip
    np.testing.assert_array_equal(median_start_velocities(short, 3, None), [[2.0], [2.0]])


def test_a_window_of_one_is_the_reference_and_the_input_is_not_changed():
    qvel = np.random.default_rng(0).normal(size=(12, 5))
    kept = qvel.copy()
    np.testing.assert_array_equal(median_start_velocities(qvel, 1, None), kept)
    median_start_velocities(qvel, 3, 6)
    np.testing.assert_array_equal(qvel, kept)
    for window in (0, 2, -3):
        with pytest.raises(ValueError, match="odd"):
            median_start_velocities(qvel, window, None)


def test_a_loops_first_row_takes_its_left_neighbour_from_the_cycles_end():
    cycle, rows = 10, 31  # one cycle, then the horizon: row r + 10 has row r's phase
    qvel = np.zeros((rows, 1))
    qvel[9::cycle], qvel[0::cycle], qvel[1::cycle] = 1.0, 3.0, 2.0
    looped = median_start_velocities(qvel, 3, cycle)
    held = median_start_velocities(qvel, 3, None)
    assert looped[0, 0] == 2.0  # median of rows 9, 0, 1: 1, 3, 2
    assert held[0, 0] == 2.0  # median of rows 0, 1, 2: 3, 2, 0: a clip that does not loop looks inside itself
    np.testing.assert_array_equal(looped[:cycle], looped[cycle:2 * cycle])
    assert looped[-1, 0] == looped[20, 0] == 2.0  # the horizon's last row: its right neighbour is row 21's phase


@pytest.fixture(scope="module")
def roll_tracks():
    motion = load_motion("deepmimic:roll")
    humanoid = Humanoid()
    return (ReferenceTrack(motion, humanoid, DT, 2.0, "reference", 1),
            ReferenceTrack(motion, humanoid, DT, 2.0, "reference", 3))


def test_roll_start_velocities_lose_their_jitter_and_keep_pose_and_reward(roll_tracks):
    raw, filtered = roll_tracks
    np.testing.assert_array_equal(raw.qpos, filtered.qpos)
    np.testing.assert_array_equal(raw.features.values, filtered.features.values)  # the reward's reference velocities
    n = raw.start_steps
    # The roll's root vertical velocity jumps row to row (0.71, 1.55, 0.12 m/s at phases .55-.58).
    jumps_raw = np.abs(np.diff(raw.qvel[:n, 2])).mean()
    jumps_filtered = np.abs(np.diff(filtered.qvel[:n, 2])).mean()
    assert jumps_filtered < 0.7 * jumps_raw
    row = int(np.argmin(np.abs(raw.phase[:n] - 0.562)))
    assert raw.qvel[row, 2] > 1.4 and filtered.qvel[row, 2] < 0.8


def test_default_env_starts_filtered_and_runs_written_before_keep_the_clips_own(roll_tracks):
    raw, _ = roll_tracks
    env = ImitationEnv(load_motion("deepmimic:roll"), EnvConfig())
    row = int(np.argmin(np.abs(raw.phase[:raw.start_steps] - 0.562)))
    assert env.track.qvel[row, 2] < 0.8 < raw.qvel[row, 2]
    with pytest.raises(ValueError, match="start_velocity_median_rows"):
        EnvConfig(start_velocity_median_rows=2)
    old = TrainConfig().to_dict()
    del old["env"]["start_velocity_median_rows"]
    assert TrainConfig.from_dict(old).env.start_velocity_median_rows == 1
