"""Side-by-side video of a reconstruction: the input video with its 2D keypoints drawn
(right side orange, left blue; the reconstruction's joints projected back in thin green; foot
contacts as discs), next to the reconstructed humanoid rendered through the camera the
reconstruction estimated (same pose of the camera, same field of view), so the halves line up.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import mujoco
import numpy as np

from actors.character.humanoid3d import Humanoid
from actors.motion.reference_motion import ReferenceMotion
from actors.character.state import StateLayout
from learner.errors import SfvError
from services.reconstruction.keypoints import JOINT_KEYPOINTS
from services.contacts.video_extras import video_start_frame
from services.render.contact_marks import draw_contacts
from services.render.keypoint_overlay import MODEL_COLOUR, draw_keypoints, project
from services.render.offscreen import OffscreenRenderer
from services.render.pinhole import set_pinhole_camera
from services.render.video_writer import AtomicVideoWriter

CAMERA_EXTRAS = ("camera_rotation", "camera_position", "camera_intrinsics", "image_size", "keypoints2d", "confidence")


def _even(n: float) -> int:
    return max(2, int(round(n / 2.0)) * 2)


def check_renderable(motion: ReferenceMotion, source: str) -> None:
    missing = [k for k in CAMERA_EXTRAS if k not in motion.extras]
    if missing:
        raise SfvError(f"{source}: motion has no {', '.join(missing)} (render-motion needs a motion made by `sfv reconstruct`)")


def render_motion_video(motion: ReferenceMotion, video: Path, out: Path, height: int = 480, source: str = "motion") -> int:
    """Write the side-by-side MP4 atomically; returns the number of frames written."""
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
    # Shadows and 4x multisampling as the reconstruction videos always had (a few frames a second).
    view = OffscreenRenderer(humanoid.model, width, height, shadows=True, antialias=True)
    free_camera = mujoco.MjvCamera()
    rendered = np.empty((height, width, 3), np.uint8)
    projected_model = project(extras["keypoints3d"], rotation, position, intrinsics) if "keypoints3d" in extras else None
    try:
        with AtomicVideoWriter(out, motion.fps) as writer:
            for video_index, frame in read_frames(video, first, first + frames):
                index = video_index - first
                pose = motion.sample(motion.frame_times[index])
                layout.pose_to_qpos_qvel(pose, data.qpos, data.qvel)
                mujoco.mj_forward(humanoid.model, data)
                view.update(data, free_camera)
                set_pinhole_camera(view.scene, rotation, position, intrinsics, image_size)
                view.render(rendered)
                left = cv2.resize(frame, (width, height), interpolation=cv2.INTER_AREA)
                draw_keypoints(left, extras["keypoints2d"][index], extras["confidence"][index], scale)
                if projected_model is not None:  # the reconstruction seen from the camera, for judging the fit
                    draw_keypoints(left, projected_model[index], np.ones(len(JOINT_KEYPOINTS)), scale,
                                   colour_override=MODEL_COLOUR, radius=2, thickness=1)
                draw_contacts(left, extras, index, scale, JOINT_KEYPOINTS)
                writer.append(np.concatenate((left, rendered), axis=1))
            if writer.frames == 0:
                raise SfvError(f"{video}: no frame could be decoded")
            return writer.frames
    finally:
        view.close()
