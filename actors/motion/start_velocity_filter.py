"""Start states' velocities with the clip's one-row spikes removed: mocap jitter is not part of the skill.

A reference's velocities are differences between neighbouring frames, so every millimetre of a
clip's jitter, a repeated frame or a skipped one becomes a velocity spike. The roll
(DeepMimic's, 59.5 fps) has runs of repeated frames: its root speed between frames swings 0.5 ->
4.2 -> 2.5 -> 5.3 -> 1.2 m/s, and at phase .56, rolling on its back, its root moves up at 0.71,
1.55 and 0.12 m/s on three neighbouring control rows. An episode started on a spike carries it:
at 5 M samples 8 of `sfv eval`'s 32 starts scored .13-.21 against .79-.82 for the other 24, and
stayed out of phase for the rest of the episode.

Each start row's velocities (every qvel entry) are the median of the `window` control rows
around it: a one-row spike goes, a step stays (a take-off or a landing changes the velocity
for good, and a median keeps such an edge where an average smears it into the rows on either
side). The same trained policies from the same poses, `sfv eval`'s 32 strict episodes with the clip's
own velocities / a Gaussian of one row (33 ms; PHC and ProtoMotions filter their
references' velocities with a Gaussian of two frames) / a median of three rows
(`bench/scripts/start_velocity_probe.py`, bench/results/acrobatics/start_velocity_filter.json):
roll .648 / .768 / .733; cartwheel .855 with 3 falls / .882 with 2 / .909 with 1; jump .935, no
fall / .883 with 2 / .909 with 1; spinkick .849, no fall / .825 with 1 / .849, no fall; the backflip
.805 with 2 falls in all three; the nine other clips within .005 of their own (dance_b's 7 falls
stay). The Gaussian's extra falls are at take-offs and landings it blurred; so the median is the
default.

Applied to start states only, before a flight's velocities are made ballistic
(`actors/motion/ballistic_flight.py`); the reward still compares against the reference's own
velocities. A looped clip's first rows take their left neighbours from the end of its cycle
(the rows are one cycle followed by the horizon, so the same phase repeats). A clip that does not
loop has no rows beyond its ends, so its first and last rows take the window's rows from inside
the clip (row 0: the median of rows 0, 1, 2): holding the end row instead counted it twice, and
a spike at a video's first frame (a subject who has just appeared) stayed in the state every
first-frame episode starts from.
"""
from __future__ import annotations

import numpy as np

MEDIAN_ROWS = 3  # the default window: one row either side removes a one-row spike and keeps a step


def median_start_velocities(qvel: np.ndarray, window: int, cycle_rows: int | None) -> np.ndarray:
    """(rows, nv) velocities, each the median over `window` rows centred on it (1: a copy).

    `window` is odd; `cycle_rows`: a looped clip's rows per cycle (row r + cycle_rows has row
    r's phase), so rows before the first come from the cycle's end; None for a clip that does
    not loop (the windows of its end rows slide inside it)."""
    qvel = np.asarray(qvel, dtype=np.float64)
    if window < 1 or window % 2 == 0:
        raise ValueError(f"the median window must be an odd number of rows, got {window}")
    rows = len(qvel)
    if window == 1 or rows < 2:
        return qvel.copy()
    radius = window // 2
    index = np.arange(-radius, rows + radius)
    if cycle_rows:
        index = np.where(index < 0, index % cycle_rows, index)
        index = np.where(index >= rows, index - cycle_rows * ((index - rows) // cycle_rows + 1), index)
        padded = qvel[np.clip(index, 0, rows - 1)]
        return np.median(np.stack([padded[j:j + rows] for j in range(window)]), axis=0)
    # Not looped: each row's window slides inside the clip at its ends (a short clip: the whole clip).
    starts = np.clip(np.arange(rows) - radius, 0, max(rows - window, 0))
    span = min(window, rows)
    return np.median(np.stack([qvel[starts + j] for j in range(span)]), axis=0)
