"""The static pinhole camera the video was taken with, in the motion's Z-up world.

World frame: z up (ground plane z = 0); world x is the image's right direction made
horizontal, so the camera's x axis lies in the world's x-z plane and the camera looks
roughly along +y. A monocular clip fixes the camera only up to this choice: any
rotation or shift of camera and motion together leaves every loss term unchanged, so the
extrinsics are set once (up direction from the body: its axis, `estimate_up`, turned to balance,
`balance_up`, and levelled along its travel, `level_along`; height from the feet) and the root
trajectory carries the rest.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from services.reconstruction.keypoints import fit_index

CAMERA_DOWN = np.array([0.0, 1.0, 0.0])  # image down in camera axes (x right, y down, z forward)


@dataclass
class PinholeCamera:
    rotation: np.ndarray  # (3, 3) world -> camera: p_cam = rotation @ (p_world - position)
    position: np.ndarray  # (3,) camera centre in the world, metres
    focal: float  # pixels
    principal: np.ndarray  # (2,) pixels
    image_size: tuple[int, int]  # (width, height)

    @property
    def intrinsics(self) -> np.ndarray:
        return np.array([[self.focal, 0.0, self.principal[0]], [0.0, self.focal, self.principal[1]], [0.0, 0.0, 1.0]])

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        return (points - self.position) @ self.rotation.T

    def project(self, points: np.ndarray) -> np.ndarray:
        cam = self.to_camera(points)
        return self.focal * cam[..., :2] / np.maximum(cam[..., 2:], 1e-6) + self.principal

    def project_torch(self, points: torch.Tensor, min_depth: float = 0.05) -> torch.Tensor:
        rotation = torch.as_tensor(self.rotation, dtype=points.dtype)
        cam = (points - torch.as_tensor(self.position, dtype=points.dtype)) @ rotation.T
        depth = cam[..., 2:].clamp_min(min_depth)
        return self.focal * cam[..., :2] / depth + torch.as_tensor(self.principal, dtype=points.dtype)

    def shifted(self, offset: np.ndarray) -> PinholeCamera:
        return PinholeCamera(self.rotation, self.position + offset, self.focal, self.principal, self.image_size)


def default_focal(image_size: tuple[int, int], focal_length_px: float = 0.0) -> float:
    return float(focal_length_px) if focal_length_px > 0 else float(max(image_size))


def estimate_up(points3d: np.ndarray, valid: np.ndarray, use_body: bool, min_consistency: float) -> np.ndarray:
    """World up in camera axes from the 3D prediction (camera axes, (T, P, 3)).

    A person who stands most of the clip has a mean unit ankle-to-shoulder axis of length
    near 1, pointing up; a flip or a roll averages to a short vector, and then the camera
    is assumed level (image up is world up).
    """
    level = -CAMERA_DOWN
    if not use_body or not valid.any():
        return level
    shoulders = points3d[valid][:, [fit_index("RShoulder"), fit_index("LShoulder")]].mean(axis=1)
    ankles = points3d[valid][:, [fit_index("RAnkle"), fit_index("LAnkle")]].mean(axis=1)
    axis = shoulders - ankles
    axis /= np.maximum(np.linalg.norm(axis, axis=-1, keepdims=True), 1e-9)
    mean = axis.mean(axis=0)
    if np.linalg.norm(mean) < min_consistency or mean @ level <= 0.0:
        return level
    return mean / np.linalg.norm(mean)


# Up from balance (`balance_up`): at least this many frames with a foot down, a mean unit
# support-to-centre-of-mass direction at least this long (the directions agree), and at most this
# far from the body's up (further means the contacts or the fit are wrong, not the up). A turn of
# less than MIN_BALANCE_TURN_DEG is within what sway leaves in the estimate (the synthetic one-leg
# stand's: 1.0 degree off the truth), and the body's up stays.
MIN_BALANCE_FRAMES = 10
MIN_BALANCE_CONSISTENCY = 0.9
MIN_BALANCE_TURN_DEG = 2.0
MAX_BALANCE_TURN_DEG = 30.0


def balance_up(com: np.ndarray, soles: np.ndarray, contacts: np.ndarray, seen: np.ndarray,
               body_up: np.ndarray) -> np.ndarray | None:
    """World up (in the frame of the inputs) from balance: the mean unit direction from the support
    (the mean sole centre of the feet down) to the centre of mass over the frames a foot is down.

    A person on the ground holds their centre of mass over their support, so that direction is
    gravity's, up to the sway of a step, which averages out over a stance or a gait cycle. The
    body's ankle-to-shoulder axis (`estimate_up`) is not: a leg lifted to the side or held back,
    a lean, and the 3D predictor's own tilt put it 8-17 degrees off the calibrated vertical on the
    eight Pose2Sim cameras (mean 12.7), and a reference that leans that far from its support is
    one no body can follow. `com` (T, 3), `soles` (T, 2, 3), `contacts` (T, 2) bool, `seen` (T,)
    bool; None when too few frames, directions that disagree, or a turn from `body_up` under
    MIN_BALANCE_TURN_DEG or over MAX_BALANCE_TURN_DEG (then the body's up stays).
    """
    down = np.asarray(contacts, bool) & np.asarray(seen, bool)[:, None]
    frames = down.any(axis=1)
    if frames.sum() < MIN_BALANCE_FRAMES:
        return None
    weights = down[frames].astype(np.float64)
    support = (soles[frames] * weights[..., None]).sum(axis=1) / weights.sum(axis=1, keepdims=True)
    direction = com[frames] - support
    direction /= np.maximum(np.linalg.norm(direction, axis=-1, keepdims=True), 1e-9)
    mean = direction.mean(axis=0)
    if np.linalg.norm(mean) < MIN_BALANCE_CONSISTENCY:
        return None
    up = mean / np.linalg.norm(mean)
    body = body_up / np.linalg.norm(body_up)
    turn = np.degrees(np.arccos(np.clip(up @ body, -1.0, 1.0)))
    if not MIN_BALANCE_TURN_DEG <= turn <= MAX_BALANCE_TURN_DEG:
        return None
    return up


# Level along the travel (`travel_direction`, `level_along`): a root path whose main direction spans
# at least MIN_TRAVEL_M, at least MIN_TRAVEL_TILT_DEG from the up (a path that rises more steeply is a
# jump or a climb, not a walk), turning the up by at most MAX_LEVEL_TURN_DEG.
MIN_TRAVEL_M = 1.0
MIN_TRAVEL_TILT_DEG = 60.0
MAX_LEVEL_TURN_DEG = 20.0


def travel_direction(path: np.ndarray, seen: np.ndarray) -> np.ndarray | None:
    """The unit main direction of a root path (T, 3) over its seen frames (the first principal axis),
    or None when it spans less than MIN_TRAVEL_M (someone who stays in place)."""
    points = np.asarray(path, np.float64)[np.asarray(seen, bool)]
    if len(points) < 2:
        return None
    centred = points - points.mean(axis=0)
    axis = np.linalg.svd(centred, full_matrices=False)[2][0]
    along = centred @ axis
    return axis if along.max() - along.min() >= MIN_TRAVEL_M else None


def level_along(up: np.ndarray, along: np.ndarray) -> np.ndarray:
    """`up` turned to be perpendicular to the travel direction `along`: a person who walks or runs
    metres does so on level ground, so the root's path is horizontal. The body's axis leans with
    the gait (a runner forward), and the ground it implies tilts along the path: a run across 3 m
    of a side view rose 0.44 m from its first frame to its last. Unchanged when the path rises
    steeply (a jump, MIN_TRAVEL_TILT_DEG) or the turn would exceed MAX_LEVEL_TURN_DEG."""
    up = up / np.linalg.norm(up)
    along = along / np.linalg.norm(along)
    if np.degrees(np.arccos(min(1.0, abs(float(up @ along))))) < MIN_TRAVEL_TILT_DEG:
        return up
    level = up - (up @ along) * along
    level /= np.linalg.norm(level)
    if np.degrees(np.arccos(np.clip(level @ up, -1.0, 1.0))) > MAX_LEVEL_TURN_DEG:
        return up
    return level


def camera_rotation_from_up(up_cam: np.ndarray) -> np.ndarray:
    """World -> camera rotation whose world z is `up_cam` and whose world x is the image's x
    axis made perpendicular to up (the camera's x axis then has no world-y component)."""
    up = up_cam / np.linalg.norm(up_cam)
    x_axis = np.array([1.0, 0.0, 0.0]) - up[0] * up
    x_axis /= np.linalg.norm(x_axis)
    y_axis = np.cross(up, x_axis)
    return np.stack((x_axis, y_axis, up), axis=1)  # columns: world axes in camera coordinates


def fit_translations(offsets_cam: np.ndarray, keypoints2d: np.ndarray, confidence: np.ndarray,
                     focal: float, principal: np.ndarray, min_depth: float = 0.5) -> np.ndarray:
    """Per frame, the camera-frame translation t that best places a body (offsets_cam (T, P, 3),
    camera axes, relative to the root) on its 2D keypoints (T, P, 2).

    Linear least squares on the cross-multiplied projection equations
    f (X + t_x) = (u - c_x)(Z + t_z), f (Y + t_y) = (v - c_y)(Z + t_z), weighted by confidence.
    A frame with fewer than two confident points (a frame the subject was not seen in, whose
    keypoints were interpolated) takes the translation interpolated in time between the nearest
    solved frames (held at the clip's ends). The median of the others, used before, is the
    middle of a walk: on the park walk read at 25 fps, one unseen frame at the start was put
    1.3 m off the path, its neighbours fitted at 139-242 px of reprojection error and the root
    moved 40 m/s there.
    """
    frames, points = offsets_cam.shape[:2]
    uv = keypoints2d - principal
    rows = np.zeros((frames, points, 2, 3))
    rows[..., 0, 0] = focal
    rows[..., 1, 1] = focal
    rows[..., :, 2] = -uv
    rhs = uv * offsets_cam[..., 2:] - focal * offsets_cam[..., :2]
    weight = np.sqrt(confidence)[..., None, None]
    a = (rows * weight).reshape(frames, 2 * points, 3)
    b = (rhs[..., None] * weight).reshape(frames, 2 * points)
    solvable = (confidence > 0.1).sum(axis=1) >= 2
    translations = np.zeros((frames, 3))
    for t in np.flatnonzero(solvable):
        translations[t] = np.linalg.lstsq(a[t], b[t], rcond=None)[0]
    good = solvable & (translations[:, 2] > min_depth)
    if not good.any():
        translations[:] = (0.0, 0.0, 3.0)
        return translations
    known, missing = np.flatnonzero(good), np.flatnonzero(~good)
    for axis in range(3):
        translations[missing, axis] = np.interp(missing, known, translations[known, axis])
    return translations
