"""A simulated motion in its scene, filmed by a follow camera, beside the video it came from.

`qpos` (T, nq) are the simulation's frames (a scene fit's final rollout); `model` is the
compiled model with the boxes where the fit put them, so the boxes are filmed as simulated.
With a video, each output frame is the video's frame (from `first_frame`, scaled to the
height) on the left and the simulation on the right; without one, the simulation alone.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import mujoco
import numpy as np

from services.render.camera import CameraConfig, FollowCamera
from services.render.offscreen import OffscreenRenderer
from services.render.video_writer import AtomicVideoWriter


def _even(n: float) -> int:
    return max(2, int(round(n / 2.0)) * 2)


def render_simulation_video(model: mujoco.MjModel, qpos: np.ndarray, fps: float, out: Path, video: Path | None = None,
                            first_frame: int = 0, height: int = 480) -> int:
    """Write the MP4 atomically; returns the frames written."""
    height = _even(height)
    frames, left_width = len(qpos), 0
    source = None
    if video is not None:
        from services.pose.video import probe_video, read_frames

        info = probe_video(video)
        left_width = _even(info.width * height / info.height)
        frames = min(frames, info.frame_count - first_frame)
        source = read_frames(video, first_frame, first_frame + frames)
    width = _even(height * 4 / 3)
    data = mujoco.MjData(model)
    camera = FollowCamera(CameraConfig())
    rendered = np.empty((height, width, 3), np.uint8)
    with OffscreenRenderer(model, width, height) as view, AtomicVideoWriter(out, fps) as writer:
        for t in range(frames):
            data.qpos[:] = qpos[t]
            mujoco.mj_kinematics(model, data)
            (camera.snap if t == 0 else camera.follow)(data.qpos[:2].copy())
            view.update(data, camera.camera)
            view.render(rendered)
            if source is None:
                writer.append(rendered)
                continue
            _, frame = next(source)
            left = cv2.resize(frame, (left_width, height), interpolation=cv2.INTER_AREA)
            writer.append(np.concatenate((left, rendered), axis=1))
        return writer.frames
