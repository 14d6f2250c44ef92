"""What a moving-camera pipeline run leaves in its output directory (each file written atomically):

    simulated.npz     the simulated motion (`sfv train --motion` / `render-motion` read it),
                      with its feet's contacts and the window of each frame as extras
    simulated.bvh     the same motion as BVH (cm)
    scene_fitted.yaml the fitted scene, a scene file `--scene` reads back (when there is a scene)
    scene_fit.json    the windows, the fit (initial and fitted e, objective per window, SLSQP
                      starts) and the simulated motion's MPJPE and contact accuracy
    simulated.mp4     (the pipeline) the simulation in the fitted scene beside the video
"""
from __future__ import annotations

from pathlib import Path

from actors.motion.formats.bvh import write_bvh
from actors.motion.formats.io import save_motion
from learner.atomic_io import atomic_write_json
from services.scene_fit import scene_contract

MOTION_FILE, BVH_FILE, SCENE_FILE, SUMMARY_FILE = "simulated.npz", "simulated.bvh", "scene_fitted.yaml", "scene_fit.json"


def write_outputs(out: Path, motion, scene, summary: dict) -> dict[str, str]:
    """Write the files; returns their paths by role."""
    out = Path(out)
    paths = {"motion": save_motion(motion, out / MOTION_FILE), "bvh": write_bvh(motion, out / BVH_FILE)}
    if scene is not None:
        paths["scene"] = scene_contract.write_scene_yaml(scene, out / SCENE_FILE)
    paths["summary"] = atomic_write_json(out / SUMMARY_FILE, summary, sort_keys=True)
    return {k: str(v) for k, v in paths.items()}


def render_simulation(outcome, out: Path, video: Path | None = None, first_frame: int = 0, height: int = 480) -> Path:
    """The final rollout filmed in its scene (the first window's env, its boxes at the fitted e),
    beside `video` from `first_frame` when given."""
    from actors.envs.imitation_env import ImitationEnv
    from actors.motion.formats.io import load_motion
    from services.render.simulation_video import render_simulation_video
    from services.training.run_dir import read_run_config

    first = outcome.runs[0]
    env = ImitationEnv(load_motion(str(first.motion_path)), read_run_config(first.train_dir).env)
    if outcome.scene_vector is not None:
        scene_contract.set_env_scene(env, first.window_e(outcome.scene_vector))
    render_simulation_video(env.model, outcome.simulated.qpos, outcome.simulated.control_hz, out, video, first_frame, height)
    return Path(out)
