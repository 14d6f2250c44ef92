"""A MuJoCo scene seen through a pinhole camera given as OpenCV-style extrinsics (world ->
camera rotation, camera centre) and intrinsics, so a render lines up with the video pixels."""
from __future__ import annotations

import numpy as np

NEAR_M, FAR_M = 0.05, 100.0


def set_pinhole_camera(scene, rotation: np.ndarray, position: np.ndarray, intrinsics: np.ndarray,
                       image_size: tuple[int, int]) -> None:
    """Point every GL camera of an updated `MjvScene` like the given camera (call between the
    renderer's `update()` and `render()`)."""
    (fx, _, cx), (_, fy, cy) = intrinsics[0], intrinsics[1]
    width, height = image_size
    for gl_camera in scene.camera:
        gl_camera.pos[:] = position
        gl_camera.forward[:] = rotation[2]  # camera +z (optical axis) in world coordinates
        gl_camera.up[:] = -rotation[1]  # image up = camera -y
        gl_camera.orthographic = 0
        gl_camera.frustum_near, gl_camera.frustum_far = NEAR_M, FAR_M
        # Image edges at pixel -0.5 and size - 0.5 (pixel centres at integers).
        gl_camera.frustum_top = NEAR_M * (cy + 0.5) / fy
        gl_camera.frustum_bottom = -NEAR_M * (height - 0.5 - cy) / fy
        gl_camera.frustum_center = NEAR_M * (width - 1 - 2 * cx) / (2 * fx)
