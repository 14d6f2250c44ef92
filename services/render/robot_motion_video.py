"""Side-by-side video of a retargeting onto a robot: the source humanoid (left) and the G1
playing the robot motion (right), each rendered by MuJoCo from a camera following its own root
(the robot's camera closer by the retargeting's scale), frame by frame at the same time.
"""
from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from actors.character.g1 import G1Model
from actors.character.humanoid3d import Humanoid
from actors.character.state import StateLayout
from actors.motion.reference_motion import ReferenceMotion
from actors.motion.robot_motion import RobotMotion
from services.render.camera import CameraConfig, FollowCamera
from services.render.caption import WHITE, draw_lines, text_scale
from services.render.offscreen import OffscreenRenderer
from services.render.video_writer import AtomicVideoWriter

MAX_FPS = 30.0
ROBOT_SCALE = 0.9  # about the G1's size against the humanoid's (the retargeting's standing-height ratio)


def render_robot_motion_video(robot: RobotMotion, source: ReferenceMotion, out: Path, height: int = 480) -> int:
    """Write the MP4 (atomically); returns the number of frames."""
    width = 2 * round(height / 3)
    humanoid = Humanoid()
    layout = StateLayout(humanoid)
    g1 = G1Model()
    source_data, robot_data = mujoco.MjData(humanoid.model), mujoco.MjData(g1.model)
    source_camera = FollowCamera(CameraConfig(smoothing=1.0))
    robot_camera = FollowCamera(CameraConfig(smoothing=1.0, distance=4.0 * ROBOT_SCALE, lookat_height=0.85 * ROBOT_SCALE))
    fps = min(MAX_FPS, robot.fps)
    times = np.arange(0.0, min(robot.duration, source.duration) + 1e-9, 1.0 / fps)
    left, right = np.empty((height, width, 3), np.uint8), np.empty((height, width, 3), np.uint8)
    with OffscreenRenderer(humanoid.model, width, height) as source_view, OffscreenRenderer(g1.model, width, height) as robot_view, \
            AtomicVideoWriter(out, fps) as video:
        titles = [f"source {source.name}", f"Unitree G1 ({robot.name})"]
        scale = text_scale(width, height, titles)
        for t in times:
            pose = source.sample(t)
            layout.pose_to_qpos_qvel(pose, source_data.qpos, source_data.qvel)
            mujoco.mj_kinematics(humanoid.model, source_data)
            row = min(int(round(t * robot.fps)), robot.num_frames - 1)
            robot_data.qpos[:7] = np.concatenate((robot.root_pos[row], robot.root_quat[row]))
            robot_data.qpos[g1.joint_qpos_adr] = robot.joint_pos[row]
            mujoco.mj_kinematics(g1.model, robot_data)
            source_camera.snap(pose.root_pos[:2])
            robot_camera.snap(robot.root_pos[row, :2])
            source_view.update(source_data, source_camera.camera)
            source_view.render(left)
            robot_view.update(robot_data, robot_camera.camera)
            robot_view.render(right)
            draw_lines(left, [(titles[0], WHITE), (f"t {t:.2f} s", WHITE)], scale)
            draw_lines(right, [(titles[1], WHITE)], scale)
            video.append(np.concatenate((left, right), axis=1))
        return video.frames
