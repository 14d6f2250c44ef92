"""report.json's `outcome`: one line saying whether the controller completed the clip from its
first frame and, if not, the first cause found, checked in this order:

1. a launch at the start: the simulated or the reference root faster than START_SPEED_M_S over
   the first START_S (two videos were thrown this way: 6.7-7.2 m/s at the start, the subject
   standing or walking at 0.1-1.1 m/s);
2. the subject barely seen just before the fall: mean keypoint confidence under
   SEEN_CONFIDENCE over the WINDOW_S before it (an occlusion, a subject leaving the frame);
3. a reference out of reach there: its contact feet floating more than FLOAT_M above the floor
   where the estimator says they are down, or root frames the reference check repaired within
   that window;
4. drift: the simulated root more than DRIFT_M from the reference's, horizontally, at the fall.
Otherwise the line says none of these was found.

A rollout the fall rule lets through may still be toppling as the clip ends: its pelvis's up axis
more than TOPPLE_DEG off the reference's at the last frame (`end_tilt_deg`). The line then says
"completed the clip's frames, but toppling at its end", and `toppling` is true in report.json (and in
its `without_residual_force`), so the pipeline's decisions (the train-on loops, the body-alone stage)
treat it as not completed. Measured (bench/results/pipeline_budget_two02.json): balancing cam01's body
alone at 150 k samples, nearly horizontal in its strip at 1.67 s, is 79 degrees off at its last frame;
five controllers upright at the end are 4-29 degrees off.
"""
from __future__ import annotations

import re

import numpy as np

from actors.character.quaternion import quat_rotate

START_S = 0.1
START_SPEED_M_S = 3.0  # a standing or walking subject's root: 0.1-1.5 m/s
WINDOW_S = 0.5
SEEN_CONFIDENCE = 0.5
FLOAT_M = 0.05
DRIFT_M = 0.5
TOPPLE_DEG = 45.0


def end_tilt_deg(rollout) -> float:
    """Degrees between the simulated and the reference pelvis's up axes at the rollout's last frame."""
    up = np.array([0.0, 0.0, 1.0])
    sim, ref = quat_rotate(rollout.qpos[-1, 3:7], up), quat_rotate(rollout.reference_qpos[-1, 3:7], up)
    return float(np.degrees(np.arccos(np.clip(sim @ ref, -1.0, 1.0))))


def toppling(rollout) -> bool:
    """Upright by the fall rule to the clip's end, but tipped more than TOPPLE_DEG off the reference there."""
    return not rollout.fell and end_tilt_deg(rollout) > TOPPLE_DEG


def _speed(qpos: np.ndarray, hz: float, steps: int) -> float:
    path = qpos[: steps + 1, :3]
    return float(np.linalg.norm(np.diff(path, axis=0), axis=1).max() * hz) if len(path) > 1 else 0.0


def _start_cause(rollout) -> str | None:
    steps = max(1, int(round(START_S * rollout.control_hz)))
    sim, ref = _speed(rollout.qpos, rollout.control_hz, steps), _speed(rollout.reference_qpos, rollout.control_hz, steps)
    if max(sim, ref) <= START_SPEED_M_S:
        return None
    return f"a launch at the start (root {sim:.1f} m/s over the first {START_S:g} s; reference {ref:.1f} m/s)"


def _window(rows: np.ndarray, fall: int, hz: float) -> np.ndarray:
    return rows[max(0, fall - int(round(WINDOW_S * hz))): fall + 1]


def _seen_cause(rows: np.ndarray, extras: dict) -> str | None:
    if "confidence" not in extras or rows.size == 0:
        return None
    seen = float(np.asarray(extras["confidence"])[rows].mean())
    if seen >= SEEN_CONFIDENCE:
        return None
    return f"the subject barely seen before it (keypoint confidence {seen:.2f} in video frames {rows[0]}-{rows[-1]} of the clip)"


def _reach_cause(rows: np.ndarray, steps: slice, ref_points, extras: dict) -> str | None:
    contacts = extras.get("contacts")
    if contacts is not None and rows.size:
        down = np.asarray(contacts, bool)[rows]
        height = ref_points.foot_heights[steps][: len(down)]
        floating = np.where(down[: len(height)], height, 0.0).max(initial=0.0)
        if floating > FLOAT_M:
            return f"a reference out of reach (a contact foot {100 * floating:.0f} cm above the floor while called down)"
    line = str(extras.get("reference_check", ""))
    near = sorted(repaired_frames(line) & set(rows.tolist()))
    if near:
        return ("a reference repaired just before it (the check re-placed its root in frames "
                f"{near[0]}-{near[-1]} of the clip)")
    return None


def repaired_frames(line: str) -> set[int]:
    """The frames a reference check's line says it repaired ("repaired the root in frames 3, 89-97")."""
    match = re.search(r"repaired the root in frames ([0-9, \-]+)", line)
    frames: set[int] = set()
    for part in (match.group(1).split(",") if match else []):
        first, _, last = part.strip().partition("-")
        if first.isdigit():
            frames.update(range(int(first), int(last if last.isdigit() else first) + 1))
    return frames


def _drift_cause(rollout, fall: int) -> str | None:
    drift = float(np.linalg.norm(rollout.qpos[fall, :2] - rollout.reference_qpos[fall, :2]))
    return f"drift ({drift:.2f} m from the reference's root at the fall)" if drift > DRIFT_M else None


def outcome_line(rollout, reconstruction, rows: np.ndarray, ref_points) -> str:
    """The line (see the module docstring); `rows` (T,) the reconstruction's frame of each control
    step (`report.video_rows`), `ref_points` the reference's `BodyPoints`."""
    seconds = (rollout.frames - 1) / rollout.control_hz
    if not rollout.fell:
        if toppling(rollout):
            tilt = end_tilt_deg(rollout)
            return (f"completed the clip's frames ({seconds:.2f} s), but toppling at its end: the pelvis {tilt:.0f} degrees "
                    "off the reference's at the last frame (the fall rule had not fired yet)")
        return f"completed: upright from the first frame to the clip's end ({seconds:.2f} s)"
    fall = min(rollout.fell_at_step if rollout.fell_at_step is not None else rollout.frames - 1, rollout.frames - 1)
    what = "diverged" if rollout.diverged else "fell"
    extras = reconstruction.extras
    window = _window(rows, fall, rollout.control_hz)
    steps = slice(max(0, fall - len(window) + 1), fall + 1)
    for cause in (_start_cause(rollout), _seen_cause(window, extras), _reach_cause(window, steps, ref_points, extras),
                  _drift_cause(rollout, fall)):
        if cause is not None:
            return f"{what} at {rollout.fell_at_s:.2f} s: first cause found: {cause}"
    return (f"{what} at {rollout.fell_at_s:.2f} s: no cause found among a launch at the start, the subject unseen, "
            "a reference out of reach and drift")
