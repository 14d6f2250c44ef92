"""`sfv task render`: a task policy's deterministic episodes as an MP4, target (and box) visible.

The target is a green disc of the success radius on the floor (for go-to with an arrow of the
requested heading; push-box's box is part of the model), the camera follows the character, and
a caption gives the task, the action space, the time and the targets reached.
"""
from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from actors.envs.tasks.vector_task_env import VectorTaskEnv
from learner.policy import NumpyPolicy
from services.render.camera import FollowCamera
from services.render.caption import PUSH_RED, WHITE, draw_lines
from services.render.offscreen import OffscreenRenderer
from services.render.video_writer import AtomicVideoWriter

TARGET_RGBA = (0.2, 0.85, 0.3, 0.6)
HEADING_RGBA = (0.2, 0.5, 0.95, 1.0)


def _add_target(renderer: OffscreenRenderer, env: VectorTaskEnv) -> None:
    scene = renderer.scene
    if scene.ngeom + 2 > scene.maxgeom:
        return
    centre = env.task.marker(0)  # mjv_initGeom takes model-style sizes: a cylinder is (radius, half-height)
    radius = env.config.success_radius
    geom = scene.geoms[scene.ngeom]
    lift = 0.01 + radius * env.arena.grade  # a level disc on a slope: its uphill edge clears the incline
    mujoco.mjv_initGeom(geom, mujoco.mjtGeom.mjGEOM_CYLINDER, np.array([radius, 0.01, 0.0]), centre + [0, 0, lift],
                        np.eye(3).ravel(), np.asarray(TARGET_RGBA, np.float32))
    scene.ngeom += 1
    heading = getattr(env.task, "heading", None)
    if heading is not None:
        start = centre + [0, 0, 0.05]
        end = start + 0.8 * np.array([np.cos(heading[0]), np.sin(heading[0]), 0.0])
        renderer.add_arrow(start, end, 0.04, HEADING_RGBA)


def _phase(env) -> str:
    """The phased push-box's phase and box, for the caption ("" for the other tasks)."""
    phase = getattr(env.task, "phase", None)
    if phase is None:
        return ""
    size = " x ".join(f"{2 * v:.2f}" for v in env.task.half_size[0])
    return f"  {'push' if phase[0] else 'go to the box'}  box {size} m, {env.task.mass[0]:.1f} kg"


def render_task(env_config, weights: dict | None, out: str | Path, episodes: int = 2, seed: int = 0, label: str = "",
                width: int = 640, height: int = 360, policy=None) -> dict:
    """`episodes` deterministic episodes of `weights` (or of `policy`, anything with `mean(obs)`:
    a latent stream of the prior-sample check) into the MP4 `out`."""
    from threadpoolctl import threadpool_limits

    env = VectorTaskEnv(env_config, 1, seed=seed)
    policy = policy or NumpyPolicy(weights, max_batch=1)
    camera = FollowCamera()
    frame = np.zeros((height, width, 3), np.uint8)
    hz = env_config.control_hz
    summary = []
    with OffscreenRenderer(env.sim.models[0], width, height) as renderer, AtomicVideoWriter(out, fps=hz) as video, \
            threadpool_limits(1, user_api="blas"):
        for episode in range(episodes):
            env.rng = np.random.default_rng(seed + episode)
            obs = env.reset()
            camera.snap(env.datas[0].qpos[:2])
            step, reached, fell = 0, 0, False
            while True:
                renderer.update(env.datas[0], camera.camera)
                _add_target(renderer, env)
                renderer.render(frame)
                lines = [(label or f"{env_config.task} ({env_config.action})", WHITE),
                         (f"episode {episode + 1}/{episodes}  t {step / hz:.1f} s  targets {reached}{_phase(env)}", WHITE)]
                if fell:
                    lines.append(("fell", PUSH_RED))
                video.append(draw_lines(frame, lines))
                obs, _, terminated, truncated, _ = env.step(policy.mean(obs))
                step += 1
                reached += int(env.reached[0])
                if terminated[0] or truncated[0]:
                    fell = bool(terminated[0])
                    break
                camera.follow(env.datas[0].qpos[:2])
            summary.append({"seconds": step / hz, "targets": reached, "fell": fell})
        frames = video.frames
    return {"video": str(out), "frames": frames, "episodes": summary}
