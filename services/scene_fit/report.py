"""report.json of a moving-camera pipeline run: how the chained windows' policies did over the clip.

The static pipeline's report (`services/pipeline/report.py`) in the moving camera's terms, with
its code reused: the outcome line (`pipeline.outcome.outcome_line`: a launch at the start, the
subject unseen, a reference out of reach), the skating, penetration and contact figures
(`report.motion_figures`) and the joint errors (`pipeline.metrics`). What differs, and why:

- a root-free motion has no root path, so the world joint error, the drift cause and the
  reprojection (the simulated world path through the moving camera) have nothing to measure
  against: the joint error is root-relative only, and the reference is placed at the
  simulated root horizontally for the outcome line;
- coverage (`coverage.py`): clip frames covered, the fall's clip frame, time and window, and
  the one line saying why the simulated motion stops early;
- windows: each window's frames, samples, training return and rollouts reaching its control end.

Keys: outcome, coverage (its line), fell, fell_at_s, fell_at_frame, fell_in_window, frames
(simulated, one per control step), clip_frames, frames_covered, covered_fraction, seconds,
clip_seconds, control_hz, samples_per_window, windows, mpjpe_mm, contact_accuracy,
root_travel_m, root_relative_joint_error_m {mean, max, per_frame}, foot_skating_m_s,
ground_penetration_m, contact_fraction (simulated / reference).
"""
from __future__ import annotations

import json

import numpy as np

from services.pipeline import metrics
from services.pipeline.outcome import outcome_line
from services.pipeline.report import HIPS, motion_figures
from services.pipeline.rollout import FirstFrameRollout, body_kinematics
from services.scene_fit.coverage import Coverage
from services.scene_fit.sequence import DONE_FILE


def _round(summary: dict, digits: int = 4) -> dict:
    return {k: (None if v is None else round(float(v), digits)) for k, v in summary.items()}


def as_first_frame_rollout(simulated, clip_steps: int) -> FirstFrameRollout:
    """The chained run in the static report's terms; the reference's horizontal root is put at
    the simulated one's (a root-free reference has no path to drift from)."""
    reference = np.array(simulated.reference_qpos, np.float64)
    reference[:, :2] = simulated.qpos[:, :2]
    fell_at = None if simulated.fell_at_frame is None else len(simulated.qpos) - 1
    return FirstFrameRollout(float(simulated.control_hz), simulated.qpos, reference, simulated.clip_frames.copy(),
                             clip_steps, fell_at, False, float("nan"), np.zeros(0))


def window_results(runs) -> list[dict]:
    """Each window's frames and training results (its window.json)."""
    out = []
    for run in runs:
        done = json.loads((run.directory / DONE_FILE).read_text())
        out.append({**run.window.to_dict(), "samples": done.get("samples"),
                    "training_normalized_return": done.get("normalized_return"),
                    "rollouts_reaching_control_end": f"{done.get('reached_control_end')}/{done.get('rollouts')}"})
    return out


def build_moving_report(simulated, humanoid, clip, cover: Coverage, runs, scores: dict) -> dict:
    """The report's figures (see the module docstring)."""
    hz = float(simulated.control_hz)
    clip_steps = int(round(float(clip.frame_times[-1]) * hz))
    rollout = as_first_frame_rollout(simulated, clip_steps)
    sim, ref = body_kinematics(humanoid, rollout.qpos), body_kinematics(humanoid, rollout.reference_qpos)
    local = metrics.joint_position_errors(sim.joints, ref.joints, centre=HIPS)
    figures = {"simulated": motion_figures(sim, hz), "reference": motion_figures(ref, hz)}
    report = {
        "outcome": outcome_line(rollout, clip, simulated.clip_frames, ref),
        "coverage": cover.line,
        "fell": cover.fell_at_frame is not None,
        **{k: v for k, v in cover.to_dict().items() if k not in ("line", "complete")},
        "frames": rollout.frames,
        "seconds": round((rollout.frames - 1) / hz, 3),
        "clip_seconds": round(float(clip.frame_times[-1]), 3),
        "control_hz": hz,
        "windows": window_results(runs),
        "mpjpe_mm": round(float(scores["mpjpe_mm"]), 2),
        "contact_accuracy": None if scores.get("contact_accuracy") is None else round(float(scores["contact_accuracy"]), 3),
        "root_travel_m": round(float(scores["root_travel_m"]), 3),
        "root_relative_joint_error_m": {**_round(metrics.summary(local)), "per_frame": [round(float(v), 4) for v in local]},
    }
    for key in ("foot_skating_m_s", "ground_penetration_m", "contact_fraction"):
        report[key] = {who: figures[who][key] for who in ("simulated", "reference")}
    return report


REPORT_FILE = "report.json"


def write_moving_report(outcome, out, extra: dict | None = None) -> dict:
    """Build the report of a `stage.SceneFitOutcome` and write it (atomically) to out/report.json."""
    from pathlib import Path

    from actors.envs.imitation_env import ImitationEnv
    from actors.motion.formats.io import load_motion
    from learner.atomic_io import atomic_write_json
    from services.training.run_dir import read_run_config

    first = outcome.runs[0]
    humanoid = ImitationEnv(load_motion(str(first.motion_path)), read_run_config(first.train_dir).env).humanoid
    report = {**(extra or {}), "samples_per_window": outcome.summary.get("samples_per_window"),
              **build_moving_report(outcome.simulated, humanoid, outcome.clip, outcome.coverage, outcome.runs,
                                    outcome.summary["scores"])}
    path = Path(out) / REPORT_FILE
    report["files"] = {**outcome.summary.get("files", {}), "report": str(path)}
    atomic_write_json(path, report)
    return report
