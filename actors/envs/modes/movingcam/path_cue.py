"""The estimated root path as a cue of the movingcam mode (issue 48 part 2): observed ahead, paid for following it.

A root-free motion carries `root_path` (T, 3) and `root_path_confidence` (T,), estimated from
foot contacts (`services/reconstruction/root_path.py`, `docs/moving-camera-path.md`). 002's
tracking terms pay nothing for travel until a scene's terms pay at a landing, and the
root-free policy jumps in place (root travel 0.10-0.19 m of the box jump's 1.06 m,
`bench/results/scene_fit.json`). With this cue:

- observation: the path's horizontal velocity at each of the reference-observation steps
  ahead (default 1 and 15), turned into the character's own heading frame, in the x, y slots
  the movingcam mode leaves 0 (no path of the reference is observed there). A velocity
  vector is the heading (its angle) and the speed (its length) without an angle's wrap.
- reward: w_path * c(t) * exp(-alpha |v_com - v_path(t)|^2) on top of r_track, c the
  path's confidence; the simulated centre of mass's horizontal velocity is compared (the
  root's swings within a stride; the path is a root's, whose stride average is the same).

Velocities, not positions: a window of the scene fit cuts the clip's frames but keeps
`root_path` in whole-clip coordinates, and a policy that strays is not pulled back to
where the estimate says it should stand; physics decides the final path. A velocity is
the path's change over PATH_SPAN_S, centred, so a stride's sway does not turn the heading.

Inactive (nothing observed, nothing paid, max reward as before) when the motion has no
`root_path` (mocap, older files, mirrored motions drop extras) or the weight is 0.
"""
from __future__ import annotations

import numpy as np

from actors.motion.formats.io import root_path_estimate

# About one walking stride (two steps, ~1 s): the velocity over it is the travel, without the
# step's surge (2 Hz) or the stride's sideways sway (1 Hz; +-0.2 m/s for a 3 cm sway over 0.5 s).
PATH_SPAN_S = 1.0


def path_velocities(path: np.ndarray, frame_times: np.ndarray, span_s: float = PATH_SPAN_S) -> np.ndarray:
    """(T, 2) horizontal velocity of `path` (T, 3) at each frame: the centred change over span_s
    (one-sided at the clip's ends)."""
    times = np.asarray(frame_times, np.float64)
    lo = np.clip(times - span_s / 2, times[0], times[-1])
    hi = np.clip(times + span_s / 2, times[0], times[-1])
    width = np.maximum(hi - lo, 1e-9)
    xy = np.asarray(path, np.float64)[:, :2]
    at = lambda t: np.stack([np.interp(t, times, xy[:, 0]), np.interp(t, times, xy[:, 1])], axis=1)  # noqa: E731
    return (at(hi) - at(lo)) / width[:, None]


class PathCue:
    """velocity (rows, 2), confidence (rows,) on the track's rows; `ahead` (rows, K) rows observed."""

    def __init__(self, track, steps: tuple[int, ...], weight: float, scale: float, batch: int):
        estimate = root_path_estimate(track.motion)
        self.weight, self.scale = float(weight), float(scale)
        self.active = estimate is not None and self.weight > 0
        if not self.active:
            return
        motion = track.motion
        path, confidence = estimate
        times = np.mod(track.times, motion.duration) if motion.loop else np.minimum(track.times, motion.duration)
        frame_v = path_velocities(path, motion.frame_times)
        self.velocity = np.stack([np.interp(times, motion.frame_times, frame_v[:, i]) for i in (0, 1)], axis=1)
        self.confidence = np.clip(np.interp(times, motion.frame_times, confidence), 0.0, 1.0)
        rows = track.rows
        self.ahead = np.minimum(np.arange(rows)[:, None] + np.asarray(steps, np.int64)[None, :], rows - 1)
        k = len(steps)
        self._rows_ahead = np.zeros((batch, k), np.int64)
        self._v_ahead = np.zeros((batch, k, 2))
        self._v_heading = np.zeros((batch, k, 2))
        self._v = np.zeros((batch, 2))
        self._c = np.zeros(batch)
        self._gap = np.zeros(batch)

    def reward(self, rows: np.ndarray, com_velocity: np.ndarray) -> np.ndarray:
        """(B,) w c exp(-alpha |v_com,xy - v_path|^2) at the envs' reference `rows`."""
        v, gap = self._v, self._gap
        np.take(self.velocity, rows, axis=0, out=v)
        np.subtract(com_velocity[:, :2], v, out=v)
        np.vecdot(v, v, out=gap)
        gap *= -self.scale
        np.exp(gap, out=gap)
        np.take(self.confidence, rows, out=self._c)
        gap *= self._c
        gap *= self.weight
        return gap

    def observe(self, rows: np.ndarray, yaw: np.ndarray, slots: np.ndarray) -> None:
        """The path's velocities ahead in each heading frame (`yaw` (B, 3, 3): v_heading = v_world @ yaw)
        into `slots` (B, K, 2)."""
        np.take(self.ahead, rows, axis=0, out=self._rows_ahead)
        np.take(self.velocity, self._rows_ahead, axis=0, out=self._v_ahead)
        np.matmul(self._v_ahead, yaw[:, :2, :2], out=self._v_heading)
        slots[...] = self._v_heading
