"""report.json of a static pipeline run: how the controller did from the clip's first frame.

Keys (lengths in metres, speeds in m/s, times in seconds, image errors in pixels):

- outcome: one line, `completed: ...` or `fell at T s: first cause found: ...` (`outcome.py`);
  reference_check: the reconstruction's reference check line (`reconstruction/plausibility.py`);
  subject_frames: the lines saying which of the subject's frames the motion covers, where that is
  not simply all it was seen in (a long gap cut or interpolated, a start left out; None when none).

- fell, fell_at_s (None when upright to the end), diverged: the strict fall rule of `sfv eval`;
- toppling, end_tilt_deg: not fallen, but the pelvis more than 45 degrees off the reference's at the
  last frame (`outcome.py`; the pipeline's decisions read it as not completed);
  normalized_return: that rule's return over the most the clip could earn.
- frames, seconds, control_hz: the rollout (one frame per control step, the first frame is the
  reconstruction's first pose).
- joint_position_error_m: per frame, the mean distance between the simulated and the
  reconstructed 12 joints (hips, knees, ankles, shoulders, elbows, wrists) in the world, mean /
  max / per_frame; root_relative_joint_error_m the same with each frame's hip midpoint
  subtracted from both (the pose without the drift of the root); world_aligned_joint_error_m after
  one turn about the vertical and shift of the whole simulated path (`metrics.aligned_joint_errors`:
  a controller beside the path is not metres of error).
- foot_skating_m_s: simulated / reference, the mean horizontal speed of the feet while in
  contact (lowest foot point within `metrics.CONTACT_HEIGHT_M` of the floor at both ends of a
  step); None where no foot stays on the floor.
- ground_penetration_m: simulated / reference, mean and max depth of the body's lowest point
  below the floor; contact_fraction: simulated / reference, the share of foot-frames in contact.
- reprojection_error_px: simulated / reference, the 12 joints projected with the
  reconstruction's camera against the video's 2D keypoints (confidence-weighted mean per
  frame, then mean / max), at the video frame of each control step; None without a camera.
  Joints behind the camera are not scored; behind_camera_frames counts the frames with one.
- residual_force_body_weight: mean / max of the residual root force the controller applied
  (`EnvConfig.residual_force`, a help no body has), as a fraction of body weight; null when
  it was trained without one. without_residual_force (only then, `finish.py`): the same
  controller from the first frame with the wrench at zero: fell, fell_at_s, toppling, normalized_return.
"""
from __future__ import annotations

import numpy as np

from actors.motion.reference_motion import ReferenceMotion
from services.pipeline import metrics
from services.pipeline.outcome import end_tilt_deg, outcome_line, toppling
from services.pipeline.rollout import BodyPoints, FirstFrameRollout, body_kinematics
from services.reconstruction.keypoints import JOINT_KEYPOINTS

HIPS = [JOINT_KEYPOINTS.index("RHip"), JOINT_KEYPOINTS.index("LHip")]
CAMERA_KEYS = ("camera_rotation", "camera_position", "camera_intrinsics", "keypoints2d", "confidence")


def video_rows(reconstruction: ReferenceMotion, times: np.ndarray) -> np.ndarray:
    """The reconstruction's frame (and so the video's, from its start frame) nearest each time."""
    rows = np.round(np.asarray(times) * reconstruction.fps).astype(np.int64)
    return np.clip(rows, 0, reconstruction.num_frames - 1)


def _rounded(summary: dict, digits: int) -> dict:
    return {k: (None if v is None else round(float(v), digits)) for k, v in summary.items()}


def motion_figures(points: BodyPoints, fps: float) -> dict:
    """Skating and penetration of one motion's points."""
    contacts = metrics.foot_contacts(points.foot_heights)
    skating = metrics.foot_skating(points.feet, contacts, fps)
    return {"foot_skating_m_s": None if skating is None else round(skating, 4),
            "ground_penetration_m": _rounded(metrics.summary(metrics.ground_penetration(points.lowest)), 4),
            "contact_fraction": round(float(contacts.mean()), 3)}


def reprojection(points: BodyPoints, reconstruction: ReferenceMotion, times: np.ndarray) -> np.ndarray | None:
    extras = reconstruction.extras
    if any(k not in extras for k in CAMERA_KEYS):
        return None
    rows = video_rows(reconstruction, times)
    return metrics.reprojection_errors(points.joints, extras["keypoints2d"][rows], extras["confidence"][rows],
                                       extras["camera_rotation"], extras["camera_position"], extras["camera_intrinsics"])


def _behind(points: BodyPoints, reconstruction: ReferenceMotion) -> int | None:
    extras = reconstruction.extras
    if "camera_rotation" not in extras:
        return None
    return int(metrics.behind_camera(points.joints, extras["camera_rotation"], extras["camera_position"]).sum())


def _nan_summary(values: np.ndarray | None) -> dict | None:
    if values is None:
        return None
    finite = values[np.isfinite(values)]
    return _rounded(metrics.summary(finite), 2)


def build_report(rollout: FirstFrameRollout, humanoid, reconstruction: ReferenceMotion) -> tuple[dict, BodyPoints, BodyPoints]:
    """The report's figures (see the module docstring), with the simulated and the reference points."""
    sim = body_kinematics(humanoid, rollout.qpos)
    ref = body_kinematics(humanoid, rollout.reference_qpos)
    hz = rollout.control_hz
    times = np.arange(rollout.frames) / hz
    world = metrics.joint_position_errors(sim.joints, ref.joints)
    local = metrics.joint_position_errors(sim.joints, ref.joints, centre=HIPS)
    aligned = metrics.aligned_joint_errors(sim.joints, ref.joints)
    sim_px, ref_px = reprojection(sim, reconstruction, times), reprojection(ref, reconstruction, times)
    report = {
        "outcome": outcome_line(rollout, reconstruction, video_rows(reconstruction, times), ref),
        "reference_check": str(reconstruction.extras.get("reference_check", "")) or None,
        "subject_frames": [str(line) for line in np.atleast_1d(reconstruction.extras.get("subject_lines", []))] or None,
        "fell": rollout.fell,
        "fell_at_s": None if rollout.fell_at_s is None else round(rollout.fell_at_s, 3),
        "toppling": toppling(rollout),  # upright by the fall rule, tipped over at the clip's end (`outcome.py`)
        "end_tilt_deg": round(end_tilt_deg(rollout), 1),
        "diverged": rollout.diverged,
        "normalized_return": round(rollout.normalized_return, 4),
        "frames": rollout.frames,
        "seconds": round((rollout.frames - 1) / hz, 3),
        "clip_seconds": round(rollout.clip_steps / hz, 3),
        "control_hz": hz,
        "joint_position_error_m": {**_rounded(metrics.summary(world), 4), "per_frame": [round(float(v), 4) for v in world]},
        "root_relative_joint_error_m": _rounded(metrics.summary(local), 4),
        "world_aligned_joint_error_m": _rounded(metrics.summary(aligned), 4),
        "reprojection_error_px": {"simulated": _nan_summary(sim_px), "reference": _nan_summary(ref_px)},
        "behind_camera_frames": _behind(sim, reconstruction),
        # the residual root force the controller used (a help no body has; null: trained without it)
        "residual_force_body_weight": None if rollout.residual_force is None or not len(rollout.residual_force)
        else _rounded(metrics.summary(rollout.residual_force), 4),
    }
    figures = {"simulated": motion_figures(sim, hz), "reference": motion_figures(ref, hz)}
    for key in ("foot_skating_m_s", "ground_penetration_m", "contact_fraction"):
        report[key] = {who: figures[who][key] for who in ("simulated", "reference")}
    return report, sim, ref
