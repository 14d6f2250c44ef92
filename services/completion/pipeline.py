"""`complete_motion`: still image -> q_bar -> closest library frame -> simulated future -> MP4."""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

import services.render  # noqa: F401  (sets MUJOCO_GL before mujoco's GL backends load)
from learner.errors import SfvError
from services.completion.config import CompletionConfig
from services.completion.image_panel import draw_image_panel
from services.completion.initial_state import initial_state
from services.completion.library import Skill, check_run_dirs, load_library
from services.completion.matching import Match, best_match
from services.completion.prediction import predict
from services.completion.still_image import estimate_still_pose, read_image
from services.completion.target_pose import target_pose_from_track
from services.render.camera import CameraConfig, FollowCamera
from services.render.caption import PUSH_RED, WHITE, draw_lines
from services.render.offscreen import OffscreenRenderer
from services.render.video_writer import AtomicVideoWriter


def check_output(out: str | Path) -> Path:
    out = Path(out)
    if out.suffix.lower() != ".mp4":
        raise SfvError(f"{out}: the video must be an .mp4 file")
    if not out.parent.is_dir():
        raise SfvError(f"{out}: folder {out.parent} does not exist")
    return out


def _match_record(skill: Skill, match: Match) -> dict:
    return {"run": str(skill.run_dir), "motion": skill.motion_name, "frame": match.row,
            "phase": float(skill.env.track.phase[match.row]), "distance": match.distance}


def complete_motion(image: str | Path, run_dirs, out: str | Path, config: CompletionConfig = CompletionConfig(),
                    models_dir: str | Path | None = None) -> dict:
    """Predict the motion of the actor in `image` with the library of trained runs `run_dirs`
    and film it into `out` (MP4, written atomically). Returns the JSON-able summary."""
    # The cheap checks first, so bad input fails before any model or run is loaded.
    config.validate()
    out = check_output(out)
    picture = read_image(image)
    run_dirs = check_run_dirs(run_dirs)
    track = estimate_still_pose(picture, image, models_dir)
    target = target_pose_from_track(track, config.fit_iterations, config.fit_lr)
    library = load_library(run_dirs)
    match, per_skill = best_match(target.root_rot[0], target.joint_rot[0], [(s.root_rot, s.joint_rot) for s in library])
    skill = library[match.skill]
    state = initial_state(skill.env, match.row, target.root_rot[0], target.joint_rot[0], float(target.root_height[0]),
                          match.yaw)
    panel = draw_image_panel(picture, track.keypoints2d[0], track.confidence[0], config.height, config.max_image_width,
                             config.min_visibility)
    film = _film(skill, match, state, panel, out, config)
    summary = {"image": str(image), "video": str(out), **_match_record(skill, match),
               "yaw_deg": math.degrees(match.yaw), "library": [_match_record(library[m.skill], m) for m in per_skill],
               "image_rotation_deg": int(track.rotation_used[0])}
    summary.update(film)
    return summary


def _film(skill: Skill, match: Match, state: np.ndarray, panel: np.ndarray, out: Path, config: CompletionConfig) -> dict:
    from threadpoolctl import threadpool_limits

    env = skill.env
    hz = env.config.control_hz
    steps = max(1, int(round(config.seconds * hz)))
    height, panel_width = panel.shape[:2]
    frame = np.empty((height, panel_width + config.sim_width, 3), np.uint8)
    frame[:, :panel_width] = draw_lines(panel.copy(), [("input image", WHITE)])
    view = np.empty((height, config.sim_width, 3), np.uint8)
    # The image's camera looked along +y of q_bar's world; q_bar was turned by `yaw`, so the
    # same viewpoint looks along azimuth 90 degrees + yaw (MuJoCo azimuth 90 looks along +y).
    camera = FollowCamera(CameraConfig(distance=config.camera_distance, azimuth=90.0 + math.degrees(match.yaw),
                                       elevation=config.camera_elevation))
    renderer = OffscreenRenderer(env.model, config.sim_width, height)
    phase = float(env.track.phase[match.row])
    title = f"{skill.motion_name}  ({skill.run_dir.name})"
    started = time.perf_counter()
    try:
        # One observation at a time: BLAS threads only add synchronisation.
        with AtomicVideoWriter(out, fps=hz) as video, threadpool_limits(limits=1):
            for progress in predict(skill, match.row, state, steps):
                (camera.snap if progress.step == 0 else camera.follow)(env.data.qpos[0:2])
                renderer.update(env.data, camera.camera)
                renderer.render(view)
                lines = [(title, WHITE), (f"from frame {match.row} (phase {phase:.2f}), distance {match.distance:.2f} rad", WHITE),
                         (f"t {progress.step / hz:5.2f} s", WHITE)]
                if progress.fell:
                    lines.append(("fell", PUSH_RED))
                frame[:, panel_width:] = draw_lines(view, lines)
                video.append(frame)
            frames = video.frames
    finally:
        renderer.close()
    seconds = time.perf_counter() - started
    ended = "fell" if progress.fell else "time" if progress.step == steps else "end of motion"
    return {"steps": progress.step, "seconds": progress.step / hz, "fell": progress.fell, "ended": ended, "frames": frames, "fps": hz,
            "width": int(frame.shape[1]), "height": height, "ms_per_frame": 1000.0 * seconds / max(frames, 1)}
