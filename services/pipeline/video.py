"""The pipeline's pictures: the video beside the reference and the simulated humanoid, and a
frame strip of the simulated character overlaid on the video (the camera-to-world check).

Both humanoids are rendered through the camera the reconstruction estimated
(`services/render/pinhole.py`: same pose, same field of view), so every panel lines up with the
video: a simulated character that leaves the person's place in the picture has drifted in the
world, and one that never covered it means the camera-to-world mapping is wrong.

- `render_pipeline_video`: per control step, [video frame with its 2D keypoints (right orange,
  left blue) and the simulated joints projected (green)] [reference humanoid] [simulated
  humanoid], captions with the video frame, time and fall state; MP4 at the control rate.
- `overlay_strip`: `count` frames evenly over the rollout, each the video frame with the
  simulated humanoid blended over it where it covers the image (MuJoCo's segmentation pass
  picks the humanoid's pixels, not the floor's), its keypoints and a caption; one PNG.
"""
from __future__ import annotations

from pathlib import Path
from typing import Callable

import cv2
import mujoco
import numpy as np

from actors.motion.reference_motion import ReferenceMotion
from learner.errors import SfvError
from services.pipeline.metrics import project_points
from services.pipeline.report import video_rows
from services.pipeline.rollout import FirstFrameRollout, body_kinematics
from services.reconstruction.keypoints import JOINT_KEYPOINTS
from services.render.caption import PUSH_RED, WHITE, draw_lines, text_band
from services.render.keypoint_overlay import MODEL_COLOUR, draw_keypoints

CAMERA_EXTRAS = ("camera_rotation", "camera_position", "camera_intrinsics", "image_size", "keypoints2d", "confidence")
OVERLAY_ALPHA = 0.6  # weight of the rendered humanoid where it covers the video


def _even(n: float) -> int:
    return max(2, int(round(n / 2.0)) * 2)


def check_camera(reconstruction: ReferenceMotion, source: str) -> None:
    missing = [k for k in CAMERA_EXTRAS if k not in reconstruction.extras]
    if missing:
        raise SfvError(f"{source}: motion has no {', '.join(missing)} (the pipeline's pictures need a motion made by "
                       "`sfv reconstruct` from a static camera)")


class _CameraView:
    """Renders humanoid poses (qpos rows) through the reconstruction's camera at a given size."""

    def __init__(self, model: mujoco.MjModel, reconstruction: ReferenceMotion, width: int, height: int):
        from services.render.offscreen import OffscreenRenderer

        extras = reconstruction.extras
        self.model = model
        self.rotation, self.position = extras["camera_rotation"], extras["camera_position"]
        self.intrinsics = extras["camera_intrinsics"]
        self.image_size = tuple(int(v) for v in extras["image_size"])
        self.view = OffscreenRenderer(model, width, height, shadows=False, antialias=False)
        self.data = mujoco.MjData(model)
        self.camera = mujoco.MjvCamera()
        self.rgb = np.empty((height, width, 3), np.uint8)
        self.segment = np.empty((height, width, 3), np.uint8)

    def _update(self, qpos: np.ndarray) -> None:
        from services.render.pinhole import set_pinhole_camera

        self.data.qpos[:] = qpos
        mujoco.mj_kinematics(self.model, self.data)
        self.view.update(self.data, self.camera)
        set_pinhole_camera(self.view.scene, self.rotation, self.position, self.intrinsics, self.image_size)

    def render(self, qpos: np.ndarray) -> np.ndarray:
        self._update(qpos)
        return self.view.render(self.rgb)

    def mask(self, qpos: np.ndarray) -> np.ndarray:
        """(H, W) bool: the pixels the humanoid (any geom not on the world body) covers."""
        self._update(qpos)
        flags = self.view.scene.flags
        flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = True
        try:
            self.view.render(self.segment)
        finally:
            flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = False
        seg = self.segment.astype(np.int64)
        ids = seg[..., 0] + 256 * seg[..., 1] + 65536 * seg[..., 2]  # scene geom index + 1; 0: nothing
        body = np.zeros(self.view.scene.ngeom + 1, bool)
        for i in range(self.view.scene.ngeom):
            geom = self.view.scene.geoms[i]
            body[i + 1] = geom.objtype == mujoco.mjtObj.mjOBJ_GEOM and self.model.geom_bodyid[geom.objid] > 0
        return body[np.clip(ids, 0, self.view.scene.ngeom)]

    def close(self) -> None:
        self.view.close()


def _frames_for(video: Path, wanted: list[int]):
    """Yield (video frame index, RGB frame) for the sorted distinct indices `wanted`."""
    from services.pose.video import read_frames

    wanted_set = set(wanted)
    for index, frame in read_frames(video, wanted[0], wanted[-1] + 1):
        if index in wanted_set:
            yield index, frame


def _video_geometry(reconstruction: ReferenceMotion, video: Path, height: int):
    from services.pose.video import probe_video

    info = probe_video(video)
    image_size = tuple(int(v) for v in reconstruction.extras["image_size"])
    if image_size != (info.width, info.height):
        raise SfvError(f"{video}: video is {info.width}x{info.height} but the motion was reconstructed from a "
                       f"{image_size[0]}x{image_size[1]} video")
    width, height = _even(info.width * height / info.height), _even(height)
    return info, width, height, np.array([width / info.width, height / info.height])


def render_pipeline_video(rollout: FirstFrameRollout, reconstruction: ReferenceMotion, humanoid, video: Path,
                          out: Path, first_frame: int = 0, height: int = 480,
                          on_frame: Callable[[int, int], None] | None = None, outcome: str | None = None) -> int:
    """Write the three-panel MP4 atomically at the control rate, `outcome` (report.json's line:
    completed, or the first cause found) in a band under every frame; returns the frames written."""
    from services.render.video_writer import AtomicVideoWriter

    check_camera(reconstruction, "motion")
    info, width, height, scale = _video_geometry(reconstruction, video, height)
    extras = reconstruction.extras
    hz = rollout.control_hz
    rows = video_rows(reconstruction, np.arange(rollout.frames) / hz)
    rows = rows[first_frame + rows < info.frame_count]
    if len(rows) == 0:
        raise SfvError(f"{video}: has no frame from {first_frame} on, where the motion starts")
    projected = project_points(body_kinematics(humanoid, rollout.qpos[:len(rows)]).joints, extras["camera_rotation"],
                               extras["camera_position"], extras["camera_intrinsics"])
    camera = _CameraView(humanoid.model, reconstruction, width, height)
    band = [text_band(outcome, 3 * width, height / 700.0)] if outcome else []
    frames = {}
    try:
        with AtomicVideoWriter(out, hz) as writer:
            source = _frames_for(video, sorted(set((first_frame + rows).tolist())))
            current = next(source)
            for k, row in enumerate(rows):
                while current[0] < first_frame + row:
                    current = next(source)
                left = cv2.resize(current[1], (width, height), interpolation=cv2.INTER_AREA)
                draw_keypoints(left, extras["keypoints2d"][row], extras["confidence"][row], scale)
                draw_keypoints(left, projected[k], np.ones(len(JOINT_KEYPOINTS)), scale, colour_override=MODEL_COLOUR,
                               radius=2, thickness=1)
                draw_lines(left, [(f"video frame {first_frame + row}", WHITE), ("keypoints; green: simulated", WHITE)])
                reference = draw_lines(camera.render(rollout.reference_qpos[k]).copy(),
                                       [("reference", WHITE), ("(reconstruction)", WHITE)])
                simulated = camera.render(rollout.qpos[k]).copy()
                fell = rollout.fell_at_step is not None and k >= rollout.fell_at_step
                state = (f"fell at {rollout.fell_at_s:.2f} s", PUSH_RED) if fell else ("upright", WHITE)
                draw_lines(simulated, [("simulated", WHITE), (f"t {k / hz:.2f} s", WHITE), state])
                writer.append(np.concatenate([np.concatenate((left, reference, simulated), axis=1)] + band, axis=0))
                if on_frame is not None:
                    on_frame(k + 1, len(rows))
            frames = writer.frames
    finally:
        camera.close()
    return frames


def strip_steps(frames: int, count: int) -> np.ndarray:
    """`count` distinct control steps evenly over a rollout of `frames` (first and last included)."""
    return np.unique(np.round(np.linspace(0, frames - 1, max(1, min(count, frames)))).astype(np.int64))


def overlay_strip(rollout: FirstFrameRollout, reconstruction: ReferenceMotion, humanoid, video: Path,
                  out: Path, first_frame: int = 0, count: int = 6, height: int = 480) -> Path:
    """Write the PNG strip atomically: the simulated humanoid over `count` video frames."""
    from learner.atomic_io import atomic_write_bytes

    check_camera(reconstruction, "motion")
    info, width, height, scale = _video_geometry(reconstruction, video, height)
    extras = reconstruction.extras
    hz = rollout.control_hz
    steps = strip_steps(rollout.frames, count)
    rows = video_rows(reconstruction, steps / hz)
    keep = first_frame + rows < info.frame_count
    steps, rows = steps[keep], rows[keep]
    if len(steps) == 0:
        raise SfvError(f"{video}: has no frame from {first_frame} on, where the motion starts")
    camera = _CameraView(humanoid.model, reconstruction, width, height)
    tiles = []
    try:
        frames = dict(_frames_for(video, sorted(set((first_frame + rows).tolist()))))
        for step, row in zip(steps, rows):
            tile = cv2.resize(frames[first_frame + row], (width, height), interpolation=cv2.INTER_AREA)
            qpos = rollout.qpos[step]
            covered = camera.mask(qpos)
            rendered = camera.render(qpos)
            tile[covered] = (OVERLAY_ALPHA * rendered[covered] + (1 - OVERLAY_ALPHA) * tile[covered]).astype(np.uint8)
            draw_keypoints(tile, extras["keypoints2d"][row], extras["confidence"][row], scale, radius=3, thickness=1)
            fell = rollout.fell_at_step is not None and step >= rollout.fell_at_step
            draw_lines(tile, [(f"frame {first_frame + row}", WHITE), (f"t {step / hz:.2f} s", PUSH_RED if fell else WHITE)])
            tiles.append(tile)
    finally:
        camera.close()
    strip = np.concatenate(tiles, axis=1)
    ok, png = cv2.imencode(".png", cv2.cvtColor(strip, cv2.COLOR_RGB2BGR))
    if not ok:
        raise SfvError(f"{out}: could not encode the strip as PNG")
    return atomic_write_bytes(out, png.tobytes())
