"""What part of the clip the chained windows' simulated motion covers, and why it stops early.

The final rollout (`final_rollout.py`) ends at a fall; a window whose episode limit
(env.max_episode_steps) is shorter than its control segment hands over early, leaving clip
frames no policy simulated. `coverage` says either in one line, which the pipeline prints and
report.json holds, so a user never takes a 40-frame motion for the whole clip.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Coverage:
    clip_frames: int  # frames of the clip
    frames_covered: int  # clip frames 0..last reached without a fall or a gap
    fell_at_frame: int | None  # clip frame of the fall
    fell_in_window: int | None
    fell_at_s: float | None  # clip time of the fall
    line: str

    @property
    def complete(self) -> bool:
        return self.frames_covered == self.clip_frames

    def to_dict(self) -> dict:
        return {"clip_frames": self.clip_frames, "frames_covered": self.frames_covered,
                "covered_fraction": round(self.frames_covered / self.clip_frames, 4), "complete": self.complete,
                "fell_at_frame": self.fell_at_frame, "fell_in_window": self.fell_in_window,
                "fell_at_s": self.fell_at_s, "line": self.line}


def _short_window(simulated, windows) -> tuple[int, int] | None:
    """(window, last clip frame it reached) of the first window that handed over before its control end."""
    for window in windows[:-1]:
        reached = simulated.clip_frames[simulated.window_of_frame == window.index]
        if reached.size and reached.max() < window.control_end:
            return window.index, int(reached.max())
    return None


def coverage(simulated, windows, frame_times: np.ndarray, file_name: str = "simulated.npz") -> Coverage:
    """The coverage of `simulated` (a `SimulatedRun`) over a clip with `frame_times` (s) cut into `windows`."""
    total = len(frame_times)
    last = int(simulated.clip_frames.max()) if len(simulated.clip_frames) else 0
    fell = simulated.fell_at_frame
    if fell is not None:
        window = int(simulated.window_of_frame[-1])
        span = windows[window]
        at = round(float(frame_times[min(fell, total - 1)]), 3)
        covered = fell + 1
        line = (f"fell at clip frame {fell} ({at:.2f} s) in window {window} (frames {span.start}..{span.end}): "
                f"{file_name} covers clip frames 0..{fell} of {total} ({100 * covered / total:.0f} %); the windows' "
                "policies need more samples (--samples) or the reference is out of reach there")
        return Coverage(total, covered, fell, window, at, line)
    short = _short_window(simulated, windows)
    if short is not None:
        window, reached = short
        line = (f"window {window} stopped at clip frame {reached} before its control end {windows[window].control_end} "
                f"(its episode limit, --env.episode-seconds, is shorter than the window): {file_name} skips clip frames "
                f"{reached + 1}..{windows[window].control_end - 1}")
        return Coverage(total, reached + 1, None, None, None, line)
    if last < total - 1:
        line = (f"stopped upright at clip frame {last} of {total} (the last window's episode limit, --env.episode-seconds): "
                f"{file_name} covers clip frames 0..{last} ({100 * (last + 1) / total:.0f} %)")
        return Coverage(total, last + 1, None, None, None, line)
    return Coverage(total, total, None, None, None, f"completed: {file_name} covers all {total} clip frames upright")
