"""The static pipeline's last step: the trained controller played against the video.

`finish_static_run(out, video, motion, run)` rolls out the run's best checkpoint
(`checkpoint="latest"`: its newest) from the clip's first frame for the clip's length
(`rollout.first_frame_rollout`) and writes, each atomically (temp file, then rename):

    simulated.npz      the simulated motion, one frame per control step (`sfv train --motion`
                       takes it), with the reconstruction's camera and the simulated joints
    simulated.bvh      the same motion as BVH
    video.mp4          the video with its keypoints | the reference humanoid | the simulated one,
                       both through the reconstruction's camera, captions with frame and fall state,
                       report.json's outcome line under every frame
    overlay_strip.png  the simulated humanoid over video frames through that camera
    overlay_strip_without_help.png  (a controller with a residual root wrench) the same strip of the
                       episode with the wrench at zero: where the body alone falls
    report.json        fall, return, joint error, skating, penetration, reprojection (`report.py`);
                       for a controller with a residual root wrench, `without_residual_force`:
                       the same first-frame episode with the wrench at zero (fell, when, return)

One line per file on stdout (for people), progress bars on stderr.
"""
from __future__ import annotations

import sys
from pathlib import Path

from learner.errors import SfvError

MOTION_FILE, BVH_FILE, VIDEO_FILE, STRIP_FILE, REPORT_FILE = (
    "simulated.npz", "simulated.bvh", "video.mp4", "overlay_strip.png", "report.json")
UNAIDED_STRIP_FILE = "overlay_strip_without_help.png"
# Extras of the reconstruction the simulated motion keeps: where the camera was, where the clip starts.
KEPT_EXTRAS = ("camera_rotation", "camera_position", "camera_intrinsics", "image_size", "video_start_frame", "person_id")


def _bar(progress: bool, total: int, desc: str):
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit="frame", disable=not progress, dynamic_ncols=True, file=sys.stderr)


def _unaided(source, reconstruction):
    """The same controller from the first frame with its residual root wrench at zero: whether
    it completes the clip by the body's own joints (the strict figures), and the rollout."""
    from services.pipeline.outcome import toppling
    from services.pipeline.rollout import WithoutWrench, first_frame_rollout
    from services.training.evaluation import make_eval_env

    alone = first_frame_rollout(WithoutWrench(source.policy), make_eval_env(reconstruction, source.env_config))
    return {"fell": alone.fell, "fell_at_s": None if alone.fell_at_s is None else round(alone.fell_at_s, 3),
            "toppling": toppling(alone), "normalized_return": round(alone.normalized_return, 4)}, alone


def _help_clause(used: dict | None, alone: dict) -> str:
    """The outcome line's note on the residual root wrench: how much the controller leaned on it,
    and how the body alone does (a user must not read a helped motion as a physical one)."""
    from services.pipeline.body_alone import ending

    share = 0.0 if not used or used["mean"] is None else used["mean"]
    return f"; with a residual root force of {100 * share:.0f} % of body weight on average (without it: {ending(alone, 'completes it too')})"


def finish_static_run(out: Path, video: Path, motion_path: Path, run_dir: Path, checkpoint: str = "best",
                      progress: bool = True, height: int = 480, strip_frames: int = 6, say=print) -> dict:
    """Write the five files into `out`; returns the report (with the files' paths under "files")."""
    import numpy as np
    from threadpoolctl import threadpool_limits

    from actors.motion.formats.bvh import write_bvh
    from actors.motion.formats.io import load_motion, save_motion
    from learner.atomic_io import atomic_write_json
    from services.contacts.video_extras import video_start_frame
    from services.pipeline.report import build_report
    from services.pipeline.rollout import first_frame_rollout, simulated_motion
    from services.pipeline.video import check_camera, overlay_strip, render_pipeline_video
    from services.training.evaluation import make_eval_env
    from services.training.policy_source import load_policy_source

    out, video, motion_path, run_dir = Path(out), Path(video), Path(motion_path), Path(run_dir)
    if not motion_path.is_file():
        raise SfvError(f"{motion_path}: no such motion file")
    reconstruction = load_motion(str(motion_path))
    check_camera(reconstruction, str(motion_path))
    source = load_policy_source(run_dir, checkpoint=checkpoint)
    env = make_eval_env(reconstruction, source.env_config)
    first = video_start_frame(reconstruction.extras)
    steps = min(env.max_episode_steps, env.track.start_steps)
    with threadpool_limits(1, user_api="blas"), _bar(progress, steps, "rollout") as bar:
        rollout = first_frame_rollout(source.policy, env, lambda done, total: bar.update(done - bar.n))
    report, sim, _ = build_report(rollout, env.humanoid, reconstruction)
    if env.core.residual is not None and env.core.residual.strength == 0:  # the help decayed to nothing in training
        report["outcome"] += "; trained with a residual root force that decayed to zero: the body alone"
    alone = None
    if env.core.residual is not None and env.core.residual.strength != 0:
        with threadpool_limits(1, user_api="blas"):
            report["without_residual_force"], alone = _unaided(source, reconstruction)
        report["outcome"] += _help_clause(report["residual_force_body_weight"], report["without_residual_force"])
    report = {"video": str(video), "motion": str(motion_path), "run": str(run_dir), "checkpoint": source.checkpoint,
              "video_start_frame": first, **report}
    files = {}
    extras = {k: reconstruction.extras[k] for k in KEPT_EXTRAS if k in reconstruction.extras}
    extras.update(keypoint_names=reconstruction.extras.get("keypoint_names", np.array([])), keypoints3d=sim.joints,
                  fell_at_s=np.array(np.nan if rollout.fell_at_s is None else rollout.fell_at_s),
                  source_video=np.array(str(video)))
    motion = simulated_motion(rollout, env, f"{reconstruction.name}_simulated", extras)
    files["motion"] = str(save_motion(motion, out / MOTION_FILE))
    say(f"simulated motion: {files['motion']} ({motion.num_frames} frames at {rollout.control_hz:g} Hz, "
        f"{'fell at %.2f s' % rollout.fell_at_s if rollout.fell else 'upright to the end'})")
    files["bvh"] = str(write_bvh(motion, out / BVH_FILE))
    say(f"simulated motion as BVH: {files['bvh']}")
    with _bar(progress, rollout.frames, "render") as bar:
        frames = render_pipeline_video(rollout, reconstruction, env.humanoid, video, out / VIDEO_FILE, first, height,
                                       lambda done, total: bar.update(done - bar.n), outcome=report["outcome"])
    files["video"] = str(out / VIDEO_FILE)
    say(f"video beside reference and simulation: {files['video']} ({frames} frames at {rollout.control_hz:g} fps)")
    files["overlay_strip"] = str(overlay_strip(rollout, reconstruction, env.humanoid, video, out / STRIP_FILE, first,
                                               strip_frames, height))
    say(f"simulated character over the video: {files['overlay_strip']}")
    if alone is not None:
        files["overlay_strip_without_help"] = str(overlay_strip(alone, reconstruction, env.humanoid, video,
                                                                out / UNAIDED_STRIP_FILE, first, strip_frames, height))
        say(f"the same without the residual root force: {files['overlay_strip_without_help']}")
    report["files"] = dict(files, report=str(out / REPORT_FILE))
    atomic_write_json(out / REPORT_FILE, report)
    error, px = report["joint_position_error_m"], report["reprojection_error_px"]["simulated"]
    say(f"report: {out / REPORT_FILE} (normalised return {report['normalized_return']:.3f}, joint error mean "
        f"{error['mean']:.3f} m / max {error['max']:.3f} m, reprojection {px['mean'] if px else float('nan'):.1f} px)")
    say(report["outcome"])
    return report
