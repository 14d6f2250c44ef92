"""The simulation video: one frame per simulated frame, the character moving in it, and the
video's frames on the left when a video is given."""
from __future__ import annotations

import imageio.v2 as imageio
import numpy as np

from actors.character.humanoid3d import Humanoid
from actors.motion.formats.io import load_motion
from actors.character.state import StateLayout
from services.render.simulation_video import render_simulation_video


def _qpos(frames: int) -> np.ndarray:
    humanoid, motion = Humanoid(), load_motion("deepmimic:walk")
    layout = StateLayout(humanoid)
    qpos, qvel = np.zeros((frames, humanoid.nq)), np.zeros(humanoid.nv)
    for t in range(frames):
        layout.pose_to_qpos_qvel(motion.sample(motion.frame_times[3 * t]), qpos[t], qvel)
    return humanoid.model, qpos


def _decode(path) -> np.ndarray:
    with imageio.get_reader(path) as reader:
        return np.stack(list(reader.iter_data()))


def test_frames_of_the_simulation_alone(tmp_path):
    model, qpos = _qpos(6)
    out = tmp_path / "sim.mp4"
    assert render_simulation_video(model, qpos, 30.0, out, height=96) == 6
    frames = _decode(out)
    assert frames.shape[0] == 6 and frames.shape[1] == 96
    assert np.abs(frames[0].astype(int) - frames[-1].astype(int)).mean() > 0.5  # the walker moved


def test_the_video_sits_on_the_left(tmp_path):
    from services.render.video_writer import AtomicVideoWriter

    video = tmp_path / "in.mp4"
    with AtomicVideoWriter(video, 30.0) as writer:
        for _ in range(4):
            writer.append(np.full((64, 80, 3), (250, 20, 20), np.uint8))
    model, qpos = _qpos(6)
    out = tmp_path / "side.mp4"
    assert render_simulation_video(model, qpos, 30.0, out, video=video, height=64) == 4  # as many as the video has
    frames = _decode(out)
    left = frames[:, :, :80].reshape(-1, 3).mean(axis=0)
    assert left[0] > 200 and left[1] < 60  # the red video
    assert frames.shape[2] == 80 + 86  # left: the video's width at this height; right: 4:3
