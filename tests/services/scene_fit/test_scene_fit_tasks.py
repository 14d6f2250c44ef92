"""The scene fit's last stages as Ray tasks (`fit_tasks.py`): on a real Ray session they give
what the in-process path gives (the fit is deterministic, the final rollouts take mean
actions), and the fitted scene lies in its domain."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from actors.motion.formats.io import load_motion
from services.scene_fit import scene_contract
from services.scene_fit.fit_tasks import run_fit_stages
from services.scene_fit.sequence import train_windows
from services.scene_fit.stage import check_inputs, plan_windows
from services.training.config import TrainConfig

SCENES = Path(__file__).resolve().parents[3] / "bench" / "scenes"


@pytest.fixture(scope="module")
def box_windows(tmp_path_factory):
    from actors.envs.imitation_env import EnvConfig

    base = TrainConfig(motion="", out="", workers=1, envs_per_worker=2, init="rsi", samples=128, runner="in_process",
                       eval_every=0, plot_every=0, torch_threads=1)
    base.ppo.batch_size, base.ppo.minibatch_size = 128, 64
    base.env = scene_contract.movingcam_env(EnvConfig(), str(SCENES / "box_jump.yaml"))
    motion_path = str(SCENES / "box_jump.npz")
    clip, scene = check_inputs(motion_path, str(SCENES / "box_jump.yaml"), base.env)
    runs = train_windows(tmp_path_factory.mktemp("fit_tasks"), plan_windows(clip.num_frames, scene), clip, scene, base,
                         rollouts=2, progress=False)
    return runs, scene


def test_ray_tasks_give_the_in_process_fit_and_rollouts(box_windows):
    from services.ray_session import ray_session

    runs, scene = box_windows
    here = run_fit_stages(runs, scene, seed=0, starts=2, use_ray=False)
    with ray_session(num_cpus=2, log_to_driver=False):
        remote = run_fit_stages(runs, scene, seed=0, starts=2)
    np.testing.assert_allclose(remote.fit.scene, here.fit.scene, atol=1e-9)
    np.testing.assert_array_equal(remote.simulated.qpos, here.simulated.qpos)
    np.testing.assert_array_equal(remote.initial.qpos, here.initial.qpos)
    bounds = scene_contract.scene_bounds(scene)
    assert np.all(here.fit.scene >= bounds[:, 0] - 1e-9) and np.all(here.fit.scene <= bounds[:, 1] + 1e-9)

