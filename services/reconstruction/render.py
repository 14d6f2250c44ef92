"""Side-by-side video of a reconstruction: the input video with its 2D keypoints drawn
(right side orange, left blue; the reconstruction's joints projected back in thin green), next
to the reconstructed humanoid rendered by MuJoCo through the camera the reconstruction
estimated (same pose of the camera, same field of view), so the two halves line up.

MuJoCo renders off-screen; the GL backend is MUJOCO_GL when set, else OSMesa (CPU) without a
display. The context is created here rather than by `mujoco.Renderer`, which fixes its
backend when `mujoco` is first imported, before a command can choose one.
"""
from __future__ import annotations

import os
from pathlib import Path

import cv2
import mujoco
import numpy as np

from learner.atomic_io import atomic_output
from learner.errors import SfvError
from actors.humanoid import Humanoid
from actors.motion import ReferenceMotion
from actors.state import StateLayout
from services.reconstruction.keypoints import JOINT_KEYPOINTS
from services.render.contact_marks import draw_contacts
from services.reconstruction.video_extras import video_start_frame

CAMERA_EXTRAS = ("camera_rotation", "camera_position", "camera_intrinsics", "image_size", "keypoints2d", "confidence")
BONES = (
    ("RHip", "RKnee"), ("RKnee", "RAnkle"), ("LHip", "LKnee"), ("LKnee", "LAnkle"), ("RHip", "LHip"),
    ("RShoulder", "LShoulder"), ("RShoulder", "RElbow"), ("RElbow", "RWrist"), ("LShoulder", "LElbow"),
    ("LElbow", "LWrist"), ("RShoulder", "RHip"), ("LShoulder", "LHip"),
)
RIGHT_COLOUR, LEFT_COLOUR, CENTRE_COLOUR, MODEL_COLOUR = (255, 80, 40), (40, 140, 255), (240, 240, 240), (60, 230, 60)
MIN_CONFIDENCE = 0.3


def gl_context(width: int, height: int):
    backend = os.environ.get("MUJOCO_GL", "").strip().lower() or ("glfw" if os.environ.get("DISPLAY") else "osmesa")
    try:
        if backend == "osmesa":
            from mujoco.osmesa import GLContext
        elif backend == "egl":
            from mujoco.egl import GLContext
        else:
            from mujoco.glfw import GLContext
        return GLContext(width, height)
    except Exception as exc:  # noqa: BLE001  (any backend failure means: cannot render here)
        raise SfvError(f"MuJoCo cannot render off-screen with MUJOCO_GL={backend} ({exc.__class__.__name__}: {exc}); "
                       "install libosmesa6 or set MUJOCO_GL=egl") from None


class PinholeView:
    """Renders a model's current state through a pinhole camera given as OpenCV-style
    extrinsics (world -> camera rotation, camera centre) and intrinsics."""

    def __init__(self, model: mujoco.MjModel, width: int, height: int):
        self.model, self.width, self.height = model, width, height
        model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
        model.vis.global_.offheight = max(model.vis.global_.offheight, height)
        self.context = gl_context(width, height)
        self.context.make_current()
        self.render_context = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_100)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self.render_context)
        self.scene = mujoco.MjvScene(model, maxgeom=1000)
        self.option, self.perturb, self.free_camera = mujoco.MjvOption(), mujoco.MjvPerturb(), mujoco.MjvCamera()
        self.viewport = mujoco.MjrRect(0, 0, width, height)
        self.pixels = np.empty((height, width, 3), dtype=np.uint8)

    def render(self, data: mujoco.MjData, rotation: np.ndarray, position: np.ndarray, intrinsics: np.ndarray,
               image_size: tuple[int, int]) -> np.ndarray:
        self.context.make_current()
        mujoco.mjv_updateScene(self.model, data, self.option, self.perturb, self.free_camera,
                               mujoco.mjtCatBit.mjCAT_ALL, self.scene)
        near, far = 0.05, 100.0
        (fx, _, cx), (_, fy, cy) = intrinsics[0], intrinsics[1]
        width, height = image_size
        for gl_camera in self.scene.camera:
            gl_camera.pos[:] = position
            gl_camera.forward[:] = rotation[2]  # camera +z (optical axis) in world coordinates
            gl_camera.up[:] = -rotation[1]  # image up = camera -y
            gl_camera.orthographic = 0
            gl_camera.frustum_near, gl_camera.frustum_far = near, far
            # Image edges at pixel -0.5 and size - 0.5 (pixel centres at integers).
            gl_camera.frustum_top = near * (cy + 0.5) / fy
            gl_camera.frustum_bottom = -near * (height - 0.5 - cy) / fy
            gl_camera.frustum_center = near * (width - 1 - 2 * cx) / (2 * fx)
        mujoco.mjr_render(self.viewport, self.scene, self.render_context)
        mujoco.mjr_readPixels(self.pixels, None, self.viewport, self.render_context)
        return np.flipud(self.pixels).copy()

    def close(self) -> None:
        self.render_context.free()
        self.context.free()


def draw_keypoints(frame: np.ndarray, keypoints: np.ndarray, confidence: np.ndarray, scale: np.ndarray,
                   colour_override=None, radius: int = 4, thickness: int = 2) -> None:
    """Draw the 12 joints (right side orange, left side blue, or one colour) and their bones
    onto frame; keypoints in pixels of the original video, scale = (sx, sy) to frame pixels."""
    points = np.round(keypoints * scale).astype(int)
    seen = confidence >= MIN_CONFIDENCE
    for a, b in BONES:
        i, j = JOINT_KEYPOINTS.index(a), JOINT_KEYPOINTS.index(b)
        if seen[i] and seen[j]:
            colour = colour_override or (RIGHT_COLOUR if a[0] == b[0] == "R" else LEFT_COLOUR if a[0] == b[0] == "L" else CENTRE_COLOUR)
            cv2.line(frame, tuple(points[i]), tuple(points[j]), colour, thickness, cv2.LINE_AA)
    for i, name in enumerate(JOINT_KEYPOINTS):
        if seen[i]:
            colour = colour_override or (RIGHT_COLOUR if name[0] == "R" else LEFT_COLOUR)
            cv2.circle(frame, tuple(points[i]), radius, colour, -1, cv2.LINE_AA)


def project(points: np.ndarray, rotation, position, intrinsics) -> np.ndarray:
    cam = (points - position) @ rotation.T
    return cam[..., :2] / np.maximum(cam[..., 2:], 1e-6) * np.diag(intrinsics)[:2] + intrinsics[:2, 2]


def _even(n: float) -> int:
    return max(2, int(round(n / 2.0)) * 2)


def check_renderable(motion: ReferenceMotion, source: str) -> None:
    missing = [k for k in CAMERA_EXTRAS if k not in motion.extras]
    if missing:
        raise SfvError(f"{source}: motion has no {', '.join(missing)} (render-motion needs a motion made by `sfv reconstruct`)")


def render_motion_video(motion: ReferenceMotion, video: Path, out: Path, height: int = 480, source: str = "motion") -> int:
    """Write the side-by-side MP4 atomically; returns the number of frames written."""
    import imageio.v2 as imageio

    from services.pose.video import probe_video, read_frames

    check_renderable(motion, source)
    info = probe_video(video)
    extras = motion.extras
    rotation, position = extras["camera_rotation"], extras["camera_position"]
    intrinsics, image_size = extras["camera_intrinsics"], tuple(int(v) for v in extras["image_size"])
    if image_size != (info.width, info.height):
        raise SfvError(f"{video}: video is {info.width}x{info.height} but the motion was reconstructed from a "
                       f"{image_size[0]}x{image_size[1]} video")
    width, height = _even(info.width * height / info.height), _even(height)
    scale = np.array([width / info.width, height / info.height])
    first = video_start_frame(extras)  # the motion may begin later in the video (its subject's first frame)
    frames = min(motion.num_frames, info.frame_count - first)

    humanoid = Humanoid()
    layout = StateLayout(humanoid)
    data = mujoco.MjData(humanoid.model)
    view = PinholeView(humanoid.model, width, height)
    projected_model = project(extras["keypoints3d"], rotation, position, intrinsics) if "keypoints3d" in extras else None
    written = 0
    try:
        with atomic_output(out, suffix=".mp4") as tmp:
            writer = imageio.get_writer(tmp, format="FFMPEG", fps=motion.fps, codec="libx264", pixelformat="yuv420p",
                                        macro_block_size=2, ffmpeg_log_level="error")
            with writer:
                for video_index, frame in read_frames(video, first, first + frames):
                    index = video_index - first
                    pose = motion.sample(motion.frame_times[index])
                    layout.pose_to_qpos_qvel(pose, data.qpos, data.qvel)
                    mujoco.mj_forward(humanoid.model, data)
                    rendered = view.render(data, rotation, position, intrinsics, image_size)
                    left = cv2.resize(frame, (width, height), interpolation=cv2.INTER_AREA)
                    draw_keypoints(left, extras["keypoints2d"][index], extras["confidence"][index], scale)
                    if projected_model is not None:  # the reconstruction seen from the camera, for judging the fit
                        draw_keypoints(left, projected_model[index], np.ones(len(JOINT_KEYPOINTS)), scale,
                                       colour_override=MODEL_COLOUR, radius=2, thickness=1)
                    draw_contacts(left, extras, index, scale, JOINT_KEYPOINTS)
                    writer.append_data(np.concatenate((left, rendered), axis=1))
                    written += 1
            if written == 0:
                raise SfvError(f"{video}: no frame could be decoded")
    finally:
        view.close()
    return written
