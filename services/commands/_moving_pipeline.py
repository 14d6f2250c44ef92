"""`sfv pipeline VIDEO --camera moving [--scene boxes.yaml]`: the moving-camera path (002 §5-6).

pose (Ray tasks) -> reconstruction (a Ray task), written root-free with the video's cues
(orientation hint, contacts) -> the windows' trainings (Ray rollout actors, one run directory
per window) -> SLSQP scene fit -> final rollout in the fitted scene -> outputs and the MP4.
Bad input is one line before any work: the scene file is read first (a box outside its
domain), the video probed, and once the motion exists, an env of it is built with the scene
(a box over the start pose; no contacts or orientation hint in movingcam mode) before training.

Each window trains for `--samples` (default `scene_fit.budget.WINDOW_SAMPLES`, measured there).
The run ends with one result line per window, the coverage line (the simulated motion covers
the clip, or where it stops and why: a fall, which window, frames covered), report.json
(`scene_fit/report.py`) and the outcome line; a fall is a result, exit 0, as in the static path.
"""
from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from learner.errors import SfvError

VIDEO_FILE = "simulated.mp4"


def _base_config(args, scene_path):
    """`sfv train`'s settings as given (`pipeline.train_config`), in 002's tracking mode with the scene."""
    from services.commands._pipeline_settings import train_config
    from services.scene_fit import scene_contract
    from services.scene_fit.budget import moving_defaults
    from services.scene_fit.windows import WINDOW_GAMMA

    base = train_config(args, motion="", out="", defaults=moving_defaults())
    base.env = scene_contract.movingcam_env(base.env, None if scene_path is None else str(scene_path))
    if "ppo.gamma" not in vars(args):
        base.ppo.gamma = WINDOW_GAMMA  # eq. 15 reads a window's first value as its cumulative reward
    return base


def _reconstruct(args, out: Path):
    from actors.motion.formats.io import save_motion
    from services.contacts.video_motion import video_motion
    from services.pose import estimate_video
    from services.reconstruction import ReconstructionConfig

    config = ReconstructionConfig()
    if args.iterations is not None:
        config = dataclasses.replace(config, iterations=args.iterations)
    track = estimate_video(args.video, models_dir=args.pose_models, use_ray=True)
    track.save(out / "track.npz")
    motion = video_motion(track, config, args.video.stem, "moving", str(args.video), say=print).motion
    return save_motion(motion, out / "motion.npz")


def run_moving(args) -> int:
    import ray

    from services.console import attach_log_file
    from services.pose.video import probe_video
    from services.ray_session import connect_ray
    from services.scene_fit import scene_contract
    from services.scene_fit.stage import run_scene_fit

    if args.scene is not None:
        scene_contract.load_scene(args.scene)  # the file's own faults (a box outside its domain) before any work
    base = _base_config(args, args.scene)
    probe_video(args.video)
    out: Path = args.out
    motion_path = out / "motion.npz"
    if motion_path.exists() and not args.resume:
        raise SfvError(f"{out}: holds a pipeline run already; pass --resume to continue it or choose another --out")
    out.mkdir(parents=True, exist_ok=True)
    attach_log_file(out)  # library output (Ray, gRPC, warnings) goes to DIR/sfv.log
    _say_budget(base)
    started_ray = connect_ray(base.ray_address)
    try:
        if not motion_path.exists():
            _reconstruct(args, out)
        outcome = run_scene_fit(str(motion_path), None if args.scene is None else str(args.scene), out, base,
                                progress=not args.quiet)
    finally:
        if started_ray:
            ray.shutdown()
    from actors.motion.formats.io import load_motion
    from services.contacts.video_extras import video_start_frame
    from services.scene_fit.outputs import render_simulation

    first = video_start_frame(load_motion(str(motion_path)).extras)  # the motion may begin later in the video
    video = str(render_simulation(outcome, out / VIDEO_FILE, args.video, first))
    report = _report(outcome, args, motion_path, video)
    summary = outcome.summary
    print(json.dumps({"motion": str(motion_path), "simulated": summary["files"]["motion"], "video": video,
                      "report": report["files"]["report"], "windows": len(summary["windows"]),
                      "scene": None if outcome.scene_vector is None else outcome.scene_vector.tolist(),
                      "fell_at_frame": report["fell_at_frame"], "frames_covered": report["frames_covered"],
                      "clip_frames": report["clip_frames"], "scores": summary["scores"]}))
    return 0


def _say_budget(base, say=print) -> None:
    from services.scene_fit.budget import minutes_per_window

    low, high = minutes_per_window(base.samples)
    say(f"training each window for {base.samples:,} samples (--samples; measured {low:g}-{high:g} min per window "
        "on 2 shared cores)")


def _report(outcome, args, motion_path: Path, video: str, say=print) -> dict:
    """report.json, then the result lines: one per window, the coverage, the report, the outcome."""
    from services.scene_fit.report import write_moving_report

    files = {**outcome.summary["files"], "video": video}
    outcome.summary["files"] = files
    report = write_moving_report(outcome, args.out, {"video": str(args.video), "motion": str(motion_path)})
    for w in report["windows"]:
        ret = w["training_normalized_return"]
        say(f"window {w['index']}: clip frames {w['start']}..{w['end']}, {w['samples'] or 0:,} samples, training return "
            f"{float('nan') if ret is None else ret:.3f}, {w['rollouts_reaching_control_end']} rollouts reached its control end")
    say(report["coverage"])
    say(f"report: {report['files']['report']} (MPJPE {report['mpjpe_mm']:.0f} mm, root travel {report['root_travel_m']:.2f} m)")
    say(report["outcome"])
    return report
