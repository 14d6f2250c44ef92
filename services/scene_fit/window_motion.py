"""A window's reference: the clip's frames of one window, as a motion of its own.

Per-frame extras (contact flags, orientation hints, keypoints: any array whose first axis is
the clip's frame count) are cut with it, so the window's env scores the same video evidence.
The horizontal root of a root-free motion is a constant that nothing tracks; a window after
the first puts it where the previous window's policy left the character (the mean of its
hand-over states), because the env places a start state's horizontal position at the
reference root's, and the boxes stand at fixed places in the world.
"""
from __future__ import annotations

import numpy as np

from actors.motion.reference_motion import ReferenceMotion
from services.scene_fit.windows import Window


def window_motion(motion: ReferenceMotion, window: Window, root_xy: np.ndarray | None = None) -> ReferenceMotion:
    """Frames window.start..window.end of `motion`, times from 0, never looped."""
    rows = slice(window.start, window.end + 1)
    frames = motion.num_frames
    extras = {k: (v[rows] if isinstance(v, np.ndarray) and v.ndim and v.shape[0] == frames else v)
              for k, v in motion.extras.items()}
    root_pos = motion.root_pos[rows].copy()
    if root_xy is not None:
        root_pos[:, :2] += np.asarray(root_xy, np.float64)[:2] - root_pos[:1, :2]
    times = motion.frame_times[rows] - motion.frame_times[window.start]
    return ReferenceMotion(f"{motion.name}-w{window.index}", times, root_pos, motion.root_rot[rows].copy(),
                           motion.joint_rot[rows].copy(), loop=False, extras=extras)


def control_steps(window: Window, motion: ReferenceMotion, control_hz: float) -> int:
    """Control steps from the window's first frame to where its policy hands over: clip frames
    and control steps differ wherever the clip's frame rate is not the control rate."""
    return int(round(float(motion.frame_times[window.control_end - window.start]) * control_hz))


def clip_frame(window: Window, motion: ReferenceMotion, row: int, control_hz: float) -> int:
    """The clip frame nearest to control step `row` of the window's episode."""
    local = np.interp(row / control_hz, motion.frame_times, np.arange(motion.num_frames))
    return window.start + int(np.rint(local))
