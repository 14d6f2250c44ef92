"""Windows trained in order (real Trainer runs, in process, tiny budgets), each starting from the
states the previous window's policy reached; resuming skips finished windows; the chained
final rollout; the outputs written whole."""
from __future__ import annotations

import json

import numpy as np
import pytest

from actors.motion.formats.io import load_motion
from services.scene_fit.final_rollout import final_rollout
from services.scene_fit.handover import WindowRollouts
from services.scene_fit.sequence import train_windows
from services.scene_fit.windows import split_windows
from services.training.config import TrainConfig


def _base() -> TrainConfig:
    base = TrainConfig(motion="", out="", workers=1, envs_per_worker=2, init="rsi", samples=128, runner="in_process",
                       eval_every=0, plot_every=0, torch_threads=1)
    base.ppo.batch_size, base.ppo.minibatch_size = 128, 64
    return base


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    out = tmp_path_factory.mktemp("scene_fit")
    clip = load_motion("deepmimic:walk")
    windows = split_windows(clip.num_frames, [(10, 0), (20, 1)], max_objects=1)
    runs = train_windows(out, windows, clip, None, _base(), rollouts=3, progress=False)
    return out, clip, windows, runs


def test_each_window_starts_from_the_previous_policys_states(trained):
    out, clip, windows, runs = trained
    assert len(runs) == 2 and all(run.done for run in runs)
    first, second = runs[0].rollouts(), runs[1].rollouts()
    handed = WindowRollouts.load(runs[1].directory / "handover.npz")
    np.testing.assert_array_equal(handed.qpos, first.handover().qpos)
    config = json.loads((runs[1].train_dir / "config.json").read_text())
    assert config["handover_states"] == str(runs[1].directory / "handover.npz")
    assert json.loads((runs[0].train_dir / "config.json").read_text())["handover_states"] is None
    # The second window's reference root sits where the first policy left the character.
    motion = load_motion(str(runs[1].motion_path))
    np.testing.assert_allclose(motion.root_pos[0, :2], first.handover().mean_root_xy)
    assert motion.num_frames == windows[1].frames
    assert second.start_obs.shape == first.start_obs.shape and len(second.reached) == 3


def test_a_finished_sequence_is_read_back_not_trained_again(trained):
    out, clip, windows, runs = trained
    stamps = [(run.directory / "window.json").stat().st_mtime_ns for run in runs]
    again = train_windows(out, windows, clip, None, _base(), rollouts=3, progress=False)
    assert [(run.directory / "window.json").stat().st_mtime_ns for run in again] == stamps


def test_final_rollout_chains_the_windows_over_the_clip(trained):
    out, clip, windows, runs = trained
    sim = final_rollout(runs)
    frames = len(sim.qpos)
    assert frames >= 2 and sim.links.shape == (frames, 15, 3) and sim.contacts.shape == (frames, 2)
    assert sim.clip_frames[0] == 0 and np.all(np.diff(sim.clip_frames) >= 0)
    if sim.fell_at_frame is None:
        assert frames == int(round(clip.duration * 30.0)) + 1 and sim.clip_frames[-1] == clip.num_frames - 1
        assert set(sim.window_of_frame.tolist()) == {0, 1}
        assert (sim.window_of_frame[sim.clip_frames < windows[0].control_end] == 0).all()
    scores = sim.scores(np.zeros((clip.num_frames, 2), bool))
    assert scores["mpjpe_mm"] > 0 and 0 <= scores["contact_accuracy"] <= 1


def test_outputs_are_written_whole(trained, tmp_path):
    from actors.character.humanoid3d import Humanoid
    from actors.character.state import StateLayout
    from services.scene_fit.outputs import write_outputs

    out, clip, windows, runs = trained
    motion = final_rollout(runs).motion("sim", StateLayout(Humanoid()))
    paths = write_outputs(tmp_path, motion, None, {"windows": [w.to_dict() for w in windows]})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene_fit.json", "simulated.bvh", "simulated.npz"]
    back = load_motion(paths["motion"])
    np.testing.assert_allclose(back.root_pos, motion.root_pos)
    assert (tmp_path / "simulated.bvh").read_text().startswith("HIERARCHY")
    assert json.loads((tmp_path / "scene_fit.json").read_text())["windows"][1]["start"] == windows[1].start
