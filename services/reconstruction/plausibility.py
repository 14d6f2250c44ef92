"""A reference a body can follow: root launches caught and repaired before training.

A reconstruction's root path comes from image position and scale, so a frame whose 2D pose is
wrong (a subject who has just appeared, an occlusion) puts the root metres off in depth for a
frame or a few. Training then starts the character with the finite difference of that jump:
Pose2Sim two-people cam02's woman, standing (median root speed 0.24 m/s), had a root speed of
13.4, 4.5 and 4.4 m/s over her first three frames, and the controller was thrown 5.3 m and lay
down by 0.53 s; a walker filmed in a park (1.1 m/s) started at 7.2 m/s and landed 9.6 m away.

Rules (speeds between neighbouring frames, m/s):
- a step whose root speed exceeds the median of the steps around it (MEDIAN_STEPS of them, the
  window shifted inward at the clip's ends) by more than SPIKE_M_S: 2 m/s gained and lost
  within 1/60 s is 120 m/s^2, 12 g, which a pelvis does not do outside an impact; the
  reconstructions' own jitter stays under it (Pose2Sim cam02 man: median 0.7 m/s, 2.6 % of steps
  above his local median by 1 m/s);
- a step faster than MAX_ROOT_M_S anywhere;
- a horizontal root speed above BOTH_FEET_DOWN_M_S while the contact estimate has both feet down
  at both frames: the contacts contradict the motion (a walk's double support moves at about
  1.1 m/s);
- a frame whose root lies more than OFF_PATH_M (horizontally) from the path the frames around it
  follow (`path_residuals`): an excursion out and back over a few frames, whose fast steps are
  their own local median (the park walk where she passes the man on the box, below).
Repair: the frames only flagged steps touch get their root re-placed, and the repaired path is
checked again (REPAIR_PASSES in all). At the clip's ends the
next good frames' median velocity is extrapolated outward; inside, the path is interpolated
linearly between the good frames on either side (a lone flagged step spreads over three
steps). Joint rotations are kept; the world keypoints move with the root. The root's height in a
re-placed frame is set so that its lowest joint is as high as the good frames' around it
(`grounded_heights`): interpolating the root's own height lowered the body of two-people cam02's
frame 90, whose pose is crouched, 6.7 cm (lowest joint 1.8 cm above the floor against 7-10 cm
around it; the reference then went 5.1 cm into the floor).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

SPIKE_M_S = 2.0
MAX_ROOT_M_S = 10.0  # a sprinter's pelvis, 10-12 m/s, is the most a video person's root can do
BOTH_FEET_DOWN_M_S = 1.5
MEDIAN_STEPS = 9
# An excursion: the root leaves the path the frames around it follow and comes back, for a few
# frames (see `off_path_frames`).
PATH_HALF_WINDOW_S = 0.5
OFF_PATH_M = 0.3
TREND_ITERATIONS = 4
SHIFTED_EXTRAS = ("keypoints3d", "raw_keypoints3d")  # world points that move with the root


@dataclass(frozen=True)
class ReferenceCheck:
    """What the check found: the flagged steps, the repaired frames and the one line saying so."""

    flagged_steps: np.ndarray  # (K,) step t joins frames t and t+1
    repaired_frames: np.ndarray  # (R,)
    line: str


def root_speeds(root_pos: np.ndarray, fps: float, horizontal: bool = False) -> np.ndarray:
    axes = slice(0, 2) if horizontal else slice(0, 3)
    return np.linalg.norm(np.diff(root_pos[:, axes], axis=0), axis=1) * fps


def local_medians(values: np.ndarray, window: int) -> np.ndarray:
    """Median of `window` neighbours of each entry, the window shifted inward at the ends (a
    held edge value would make an edge spike its own median)."""
    count = len(values)
    width = min(window, count)
    starts = np.clip(np.arange(count) - width // 2, 0, count - width)
    return np.array([np.median(values[s:s + width]) for s in starts])


def flag_steps(root_pos: np.ndarray, fps: float, contacts: np.ndarray | None) -> dict[str, np.ndarray]:
    """{rule: (T-1,) bool} of the module docstring's rules."""
    speed = root_speeds(root_pos, fps)
    flags = {"spike": speed > local_medians(speed, MEDIAN_STEPS) + SPIKE_M_S, "too fast": speed > MAX_ROOT_M_S}
    if contacts is not None and len(contacts) == len(root_pos):
        both = np.asarray(contacts, bool).all(axis=1)
        flags["both feet down"] = both[:-1] & both[1:] & (root_speeds(root_pos, fps, horizontal=True) > BOTH_FEET_DOWN_M_S)
    return flags


def _windows(count: int, half: int) -> np.ndarray:
    """(count,) first index of each entry's window of 2 * half + 1, shifted inward at the ends."""
    width = min(2 * half + 1, count)
    return np.clip(np.arange(count) - half, 0, count - width)


def path_residuals(root_pos: np.ndarray, fps: float) -> np.ndarray:
    """(T,) horizontal distance in metres of each frame's root from the path of the frames around
    it: a quadratic in time fitted over PATH_HALF_WINDOW_S either side (the window shifted inward at
    the ends), robustly (Tukey's bisquare with its cut at OFF_PATH_M, so frames that far off get no
    weight; started from a line through the window's median position at its median step's velocity,
    which a minority of displaced frames cannot move). A quadratic follows a walker who speeds up,
    slows down or turns round, where a line would read a sprinter's start as off its path."""
    xy = np.asarray(root_pos, float)[:, :2]
    count = len(xy)
    if count < 5:
        return np.zeros(count)
    half = max(2, int(round(PATH_HALF_WINDOW_S * fps)))
    width = min(2 * half + 1, count)
    starts = _windows(count, half)
    index = starts[:, None] + np.arange(width)  # (T, W) the frames of each window
    points = xy[index]  # (T, W, 2)
    offsets = (index - np.arange(count)[:, None]) / fps  # seconds from the centre frame
    design = np.stack([np.ones_like(offsets), offsets, offsets ** 2], axis=-1)  # (T, W, 3)
    velocity = np.median(np.diff(points, axis=1), axis=1) * fps  # (T, 2) the window's median step
    centre = np.median(points - offsets[..., None] * velocity[:, None], axis=1)  # (T, 2)
    residual = np.linalg.norm(points - centre[:, None] - offsets[..., None] * velocity[:, None], axis=-1)
    for _ in range(TREND_ITERATIONS):
        weight = np.clip(1.0 - (residual / OFF_PATH_M) ** 2, 0.0, None) ** 2
        weighted = design * weight[..., None]
        normal = np.einsum("twi,twj->tij", weighted, design) + 1e-9 * np.eye(3)
        coeffs = np.linalg.solve(normal, np.einsum("twi,twk->tik", weighted, points))  # (T, 3, 2)
        residual = np.linalg.norm(points - np.einsum("twi,tik->twk", design, coeffs), axis=-1)
    return residual[np.arange(count), np.arange(count) - starts]


def off_path_frames(root_pos: np.ndarray, fps: float, residual: np.ndarray | None = None) -> np.ndarray:
    """(T,) bool: frames whose root is more than OFF_PATH_M from the path around it. The park
    walk's root went 5.2-5.4 m/s out over frames 88-90 and 4.2-5.0 back over 93-96, where she
    passes the man on the box: a plateau of fast steps raises the local median that the spike
    rule compares with, so that rule repaired one frame of it and left 5.4 m/s. Each such run of
    frames takes in the frames beside it that are more than a third of OFF_PATH_M off: anchored on
    an excursion's first or last frame (0.3 m off), the interpolation left 4.2 m/s in the test's
    excursion."""
    residual = path_residuals(root_pos, fps) if residual is None else residual
    off = residual > OFF_PATH_M
    near = residual > OFF_PATH_M / 3  # an excursion's own edges: the repair's anchors must be on the path
    grown = off.copy()
    for first, last in flag_runs(near):
        grown[first:last + 1] |= off[first:last + 1].any()
    return grown


def bad_frames(flagged: np.ndarray) -> np.ndarray:
    """(T,) bool: frames to re-place, from (T-1,) flagged steps (see the module docstring)."""
    steps = len(flagged)
    bad = np.zeros(steps + 1, bool)
    for first, last in flag_runs(flagged):
        touched = np.arange(first + 1, last + 1)  # frames with flagged steps on both sides
        if first == 0:
            touched = np.arange(0, last + 1)
        if last == steps - 1:
            touched = np.union1d(touched, np.arange(first + 1, steps + 1))
        if touched.size == 0:  # a lone step inside: spread it over the frames at its ends
            touched = np.array([first, first + 1])
        bad[touched] = True
    if bad.all():
        bad[:] = False  # nothing good to repair from: leave it, the line says so
    return bad


def flag_runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) of each run of True in a (T,) bool array, both inclusive."""
    edges = np.diff(np.concatenate(([0], flags.astype(np.int8), [0])))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1))


def repaired_root(root_pos: np.ndarray, bad: np.ndarray, fps: float) -> np.ndarray:
    """Root positions with the `bad` frames re-placed (ends extrapolated, inside interpolated)."""
    good = np.flatnonzero(~bad)
    fixed = root_pos.copy()
    frames = np.arange(len(root_pos))
    for axis in range(3):
        fixed[bad, axis] = np.interp(frames[bad], good, root_pos[good, axis])
    for end, direction in ((good[0], 1), (good[-1], -1)):
        ahead = good[(good - end) * direction >= 0][:: direction][:MEDIAN_STEPS // 2 + 1]
        velocity = np.median(np.diff(root_pos[np.sort(ahead)], axis=0), axis=0) if ahead.size > 1 else np.zeros(3)
        outside = frames[(frames - end) * direction < 0]
        fixed[outside] = root_pos[end] + np.outer(outside - end, velocity)
    return fixed


def grounded_heights(fixed: np.ndarray, root_pos: np.ndarray, keypoints: np.ndarray, bad: np.ndarray) -> np.ndarray:
    """`fixed` with the root height of the `bad` frames set so that each one's lowest joint
    (keypoints (T, J, 3), world, moving with the root) is at the height interpolated from the
    good frames' lowest joints (the nearest good frame's beyond the ends)."""
    lowest = keypoints[..., 2].min(axis=1) - root_pos[:, 2]  # lowest joint below the root, per frame
    good = np.flatnonzero(~bad)
    target = np.interp(np.flatnonzero(bad), good, (lowest + root_pos[:, 2])[good])
    grounded = fixed.copy()
    grounded[bad, 2] = target - lowest[bad]
    return grounded


def check_reference(motion, contacts: np.ndarray | None = None):
    """(motion, ReferenceCheck): `motion` (a ReferenceMotion) with its root repaired where flagged
    (a new motion, velocities from the repaired path; the same one when nothing is flagged) and
    what was found and done, in one line. The check runs again on the repaired path, up to
    REPAIR_PASSES times: a run of wrong frames at the clip's start makes its own local median,
    so only its worst steps are flagged at first (the park walk behind a pole: 31 m/s flagged,
    the four steps before it at 6.8-8.1 m/s left, and the controller would start at 7 m/s)."""
    checked, check, found = _check_once(motion, contacts)
    if check.repaired_frames.size == 0:
        return checked, check
    frames = set(check.repaired_frames.tolist())
    for _ in range(REPAIR_PASSES - 1):
        again, more, _ = _check_once(checked, contacts)
        if more.repaired_frames.size == 0:
            break
        checked = again
        frames.update(more.repaired_frames.tolist())
    frames = np.array(sorted(frames))
    after = root_speeds(checked.root_pos, float(checked.fps)).max()
    return checked, ReferenceCheck(check.flagged_steps, frames, found + f"; repaired the root in frames {_ranges(frames)} "
                                   f"(now at most {after:.2f} m/s)")


REPAIR_PASSES = 3
# The clip's start is where a subject comes into view (its end, mirrored, where one leaves), often
# from behind something: BlazePose then reads a half-hidden body, and the frames' poses are wrong
# along with their root, which the repair above cannot mend. A root whose velocity changes by more than EDGE_DV_M_S from one step
# to the next within the first EDGE_S (18 g at 30 fps, 37 g at 60) is such a start: the park walk
# behind a pole, where she steps out from behind a tree, 15.7 m/s; the development set's
# reconstructions at most 1.2 (their first half second; 0.2-0.6 on the Pose2Sim cameras); the
# synthetic test clips' noisy quick fits up to 5.4.
EDGE_S, EDGE_DV_M_S = 0.5, 6.0  # either end of the clip (`unsettled_start`, `unsettled_end`)


def unsettled_start(motion) -> tuple[int, float]:
    """(frames to leave out at the clip's start, the largest velocity change there in m/s): up to
    and including the last frame within EDGE_S at which the root's velocity changes by more than
    EDGE_DV_M_S; (0, that change) when none does."""
    return _unsettled_head(np.asarray(motion.root_pos), float(motion.fps))


def unsettled_end(motion) -> tuple[int, float]:
    """The same at the clip's end, a subject leaving the view: (frames to leave out at the end, the
    largest velocity change within EDGE_S of it). Measured on the reconstructions before the
    check's repair (`video_motion` judges both ends there): a walker leaving a plain-walled room at
    the frame's edge, 164.9 m/s (9 frames cut; the repair alone left 43 m/s); Pose2Sim two-people
    cam03's man where he passes behind the woman, 12.6 m/s (24 frames); the other development
    videos at most 3.7 (balancing cam02, two-people cam02)."""
    return _unsettled_head(np.asarray(motion.root_pos)[::-1], float(motion.fps))


def _unsettled_head(root_pos: np.ndarray, fps: float) -> tuple[int, float]:
    velocity = np.diff(root_pos, axis=0) * fps
    change = np.linalg.norm(np.diff(velocity, axis=0), axis=1)  # change[k]: at frame k + 1
    head = change[:max(1, int(round(EDGE_S * fps)))]
    if head.size == 0:
        return 0, 0.0
    jolts = np.flatnonzero(head > EDGE_DV_M_S)
    return (int(jolts[-1]) + 2 if jolts.size else 0), float(head.max())


def _check_once(motion, contacts):
    """(motion repaired or as is, ReferenceCheck, the line's finding: "" when nothing is flagged)."""
    fps = float(motion.fps)
    flags = flag_steps(motion.root_pos, fps, contacts)
    flagged = np.logical_or.reduce(list(flags.values()))
    residual = path_residuals(motion.root_pos, fps)
    off_path = off_path_frames(motion.root_pos, fps, residual)
    speed = root_speeds(motion.root_pos, fps)
    if not flagged.any() and not off_path.any():
        return motion, ReferenceCheck(np.zeros(0, int), np.zeros(0, int), f"reference check: the root moves at "
                                      f"{np.median(speed):.2f} m/s (median), at most {speed.max():.2f} m/s between frames; "
                                      "nothing to repair"), ""
    bad = bad_frames(flagged) | off_path
    if bad.all():
        bad[:] = False
    steps = np.flatnonzero(flagged)
    found = "reference check: " + "; ".join(_findings(flags, steps, speed, residual, off_path))
    if not bad.any():
        return motion, ReferenceCheck(steps, np.zeros(0, int), found + "; no plausible frame to repair from, left as is"), found
    fixed = repaired_root(motion.root_pos, bad, fps)
    if "keypoints3d" in motion.extras:
        fixed = grounded_heights(fixed, motion.root_pos, np.asarray(motion.extras["keypoints3d"]), bad)
    shift = fixed - motion.root_pos
    extras = dict(motion.extras)
    for key in SHIFTED_EXTRAS:
        if key in extras:
            extras[key] = extras[key] + shift[:, None]
    repaired = dataclasses.replace(motion, root_pos=fixed, extras=extras)  # velocities from the repaired path
    frames = np.flatnonzero(bad)
    after = root_speeds(fixed, fps).max()
    return repaired, ReferenceCheck(steps, frames, found + f"; repaired the root in frames {_ranges(frames)} "
                                    f"(now at most {after:.2f} m/s)"), found


def _findings(flags, steps, speed, residual, off_path) -> list[str]:
    """The line's findings: the fastest flagged step and the rules that flagged steps; the frames off
    the path and how far."""
    findings = []
    if steps.size:
        worst = int(steps[np.argmax(speed[steps])])
        rules = ", ".join(name for name, f in flags.items() if f.any())
        findings.append(f"the root moves {speed[worst]:.1f} m/s between frames {worst} and {worst + 1} "
                        f"(clip median {np.median(speed):.2f} m/s; {len(steps)} step(s) flagged: {rules})")
    if off_path.any():
        findings.append(f"the root leaves the path of the frames around it by up to {residual.max():.2f} m "
                        f"(frame {int(np.argmax(residual))}; more than {OFF_PATH_M} m in frames "
                        f"{_ranges(np.flatnonzero(residual > OFF_PATH_M))})")
    return findings


def _ranges(frames: np.ndarray) -> str:
    runs = flag_runs(np.isin(np.arange(frames.max() + 1), frames))
    return ", ".join(f"{a}" if a == b else f"{a}-{b}" for a, b in runs)
