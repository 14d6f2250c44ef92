"""PoseTrack: a video's per-frame 2D and 3D BlazePose landmarks, saved as .npz.

Coordinate frames
- keypoints2d: image pixels, x right, y down, origin at the top-left pixel centre.
- world3d: BlazePose "world landmarks", metres, origin midway between the hips, axes
  aligned with the camera image: x to the image's right, y down, z away from the camera
  (larger z is farther; a right-handed frame like OpenCV's camera frame).
"""
from __future__ import annotations

import zipfile
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from learner.errors import SfvError
from services.pose.atomic import write_atomically

KEYPOINT_NAMES: tuple[str, ...] = (
    "nose", "left_eye_inner", "left_eye", "left_eye_outer", "right_eye_inner", "right_eye", "right_eye_outer",
    "left_ear", "right_ear", "mouth_left", "mouth_right", "left_shoulder", "right_shoulder", "left_elbow",
    "right_elbow", "left_wrist", "right_wrist", "left_pinky", "right_pinky", "left_index", "right_index",
    "left_thumb", "right_thumb", "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle",
    "left_heel", "right_heel", "left_foot_index", "right_foot_index",
)


OPTIONAL_FIELDS = ("start_frame", "person_id")
OPTIONAL_ARRAYS = ("camera_homography", "camera_inliers")


@dataclass
class PoseTrack:
    fps: float
    image_size: tuple[int, int]  # (width, height) pixels
    keypoints2d: np.ndarray      # (T, 33, 2) float32 pixels
    confidence: np.ndarray       # (T, 33) float32 landmark visibility in [0, 1]; 0 on filled frames
    world3d: np.ndarray          # (T, 33, 3) float32 metres (see module docstring for axes)
    valid: np.ndarray            # (T,) bool: a person was found in this frame (False = filled)
    presence: np.ndarray         # (T,) float32 pose presence probability (0 on filled frames)
    rotation_used: np.ndarray    # (T,) int16 degrees the frame was turned clockwise for the kept answer
    filled_frames: int           # frames with valid=False whose landmarks were interpolated
    keypoint_names: tuple[str, ...] = KEYPOINT_NAMES
    # Optional (files written before several people were tracked lack them): the video frame
    # of row 0 (`--frames A:B`), and which identity of `sfv pose --people` this track follows.
    start_frame: int = 0
    person_id: int = 0
    # Optional: the camera's motion into each frame from the one before (services/pose/camera_motion.py).
    camera_homography: np.ndarray | None = None  # (T, 3, 3) previous -> this frame pixels; NaN where untracked
    camera_inliers: np.ndarray | None = None     # (T,) background points the homography rests on

    def __len__(self) -> int:
        return len(self.valid)

    def save(self, path: str | Path) -> Path:
        """Write atomically (temp file in the same directory, then os.replace)."""
        path = Path(path)
        if not path.parent.is_dir():
            raise SfvError(f"{path}: directory {path.parent} does not exist")
        arrays = {f.name: np.asarray(getattr(self, f.name)) for f in fields(self) if getattr(self, f.name) is not None}
        return write_atomically(path, lambda handle: np.savez_compressed(handle, **arrays))

    @classmethod
    def load(cls, path: str | Path) -> PoseTrack:
        path = Path(path)
        if not path.is_file():
            raise SfvError(f"{path}: no such pose track file")
        try:
            with np.load(path, allow_pickle=False) as data:
                values = {f.name: data[f.name] for f in fields(cls) if f.name not in OPTIONAL_FIELDS + OPTIONAL_ARRAYS}
                optional = {name: int(data[name]) for name in OPTIONAL_FIELDS if name in data.files}
                optional.update({name: data[name] for name in OPTIONAL_ARRAYS if name in data.files})
        except KeyError as exc:
            raise SfvError(f"{path}: not a pose track (missing array {exc})") from exc
        except (OSError, ValueError, zipfile.BadZipFile) as exc:
            raise SfvError(f"{path}: not a readable .npz pose track ({exc})") from exc
        track = cls(
            fps=float(values["fps"]),
            image_size=tuple(int(v) for v in values["image_size"]),
            keypoints2d=values["keypoints2d"], confidence=values["confidence"], world3d=values["world3d"],
            valid=values["valid"].astype(bool), presence=values["presence"], rotation_used=values["rotation_used"],
            filled_frames=int(values["filled_frames"]),
            keypoint_names=tuple(str(n) for n in values["keypoint_names"]),
            **optional,
        )
        track.check(path)
        return track

    def check(self, source: str | Path = "pose track") -> None:
        """Shapes agree with each other; an SfvError naming `source` otherwise."""
        frames, joints = len(self.valid), len(self.keypoint_names)
        expected = {"keypoints2d": (frames, joints, 2), "confidence": (frames, joints), "world3d": (frames, joints, 3),
                    "presence": (frames,), "rotation_used": (frames,)}
        if self.camera_homography is not None:
            expected.update(camera_homography=(frames, 3, 3), camera_inliers=(frames,))
        for name, shape in expected.items():
            value = getattr(self, name)
            actual = None if value is None else value.shape
            if actual != shape:
                raise SfvError(f"{source}: {name} has shape {actual}, expected {shape}")


def fill_gaps(values: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Linear interpolation over time of every frame where valid is False; gaps at either
    end hold the nearest valid frame. `values` is (T, ...); at least one frame valid."""
    frames = len(valid)
    flat = values.reshape(frames, -1).astype(np.float64)
    known = np.flatnonzero(valid)
    missing = np.flatnonzero(~valid)
    if missing.size:
        for column in range(flat.shape[1]):
            flat[missing, column] = np.interp(missing, known, flat[known, column])
    return flat.reshape(values.shape).astype(values.dtype)
