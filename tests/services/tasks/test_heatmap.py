"""The go-to heatmap places each episode's first target where its cell says (004 Fig. 6B)."""
import json

import numpy as np
import pytest

from actors.envs.tasks.config import TaskEnvConfig
from learner.errors import SfvError
from services.tasks.heatmap import grid_offsets, place_targets, success_heatmap, write_heatmap


class StandStill:
    def mean(self, obs):
        return np.zeros((len(obs), 28), np.float32)


def test_targets_sit_at_their_cells_in_the_heading_frame():
    from actors.envs.tasks.vector_task_env import VectorTaskEnv

    env = VectorTaskEnv(TaskEnvConfig(action="joint", horizon_s=0.2), 8, seed=3)
    env.reset()
    offsets = grid_offsets(3, 2.0)[[0, 1, 2, 3, 5, 6, 7, 8]]
    obs = place_targets(env, offsets)
    task_features = obs[:, env.proprio_dim:]
    np.testing.assert_allclose(task_features[:, :2], offsets, atol=1e-5)  # target x ahead, y left
    angle = np.arctan2(offsets[:, 1], offsets[:, 0])  # requested heading: toward the target
    np.testing.assert_allclose(task_features[:, 4:6], np.stack((np.cos(angle), np.sin(angle)), axis=1), atol=1e-5)


def test_cells_within_the_success_radius_succeed_and_the_others_do_not(tmp_path):
    # 1 m cells with a 1.2 m radius: the four beside the walker are reached on the first step,
    # the diagonal ones (1.41 m) are not (one step: a run start moves 0.12 m in it).
    config = TaskEnvConfig(action="joint", horizon_s=1 / 30, success_radius=1.2)
    record = success_heatmap(config, StandStill(), grid=3, extent=1.0, episodes_per_cell=1)
    success = np.array(record["success"])
    assert np.isnan(success[1, 1])  # the walker's own cell
    np.testing.assert_array_equal(success[[0, 1, 1, 2], [1, 0, 2, 1]], 1.0)
    np.testing.assert_array_equal(success[[0, 0, 2, 2], [0, 2, 0, 2]], 0.0)
    write_heatmap(record, tmp_path / "map.png", "test")
    assert (tmp_path / "map.png").read_bytes()[:4] == b"\x89PNG"
    assert json.loads((tmp_path / "map.json").read_text())["grid"] == 3


def test_a_push_box_run_is_refused():
    with pytest.raises(SfvError, match="go-to targets"):
        success_heatmap(TaskEnvConfig(task="push_box", action="joint"), StandStill(), grid=3)
