"""`render_policy`: roll a policy out in the imitation env and film it beside its reference.

The ghost is the same MuJoCo model posed on the reference: a second `MjData` whose qpos is
the reference track's row for the current control step, shifted sideways, added to the
scene with `mjv_addGeoms` and tinted translucent blue. Nothing is added to the simulated
model, so the physics being filmed is exactly the physics that was trained (a second body
in the MJCF would change nq, the state layout and the contacts).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from actors.envs.imitation_env import ImitationEnv
from learner.errors import SfvError
from services.export.rollout import episode_limit, episode_steps
from services.render.camera import CameraConfig, FollowCamera
from services.render.caption import PUSH_RED, WHITE, draw_lines, text_scale
from services.render.offscreen import OffscreenRenderer
from actors.envs.pushes import PushConfig, PushSchedule, apply_push
from services.render.video_writer import AtomicVideoWriter

MAX_SIDE = 4096


@dataclass(frozen=True)
class RenderConfig:
    width: int = field(default=640, metadata={"help": "frame width in pixels (even)"})
    height: int = field(default=480, metadata={"help": "frame height in pixels (even)"})
    episodes: int = field(default=1, metadata={"help": "episodes filmed one after another"})
    seconds: float | None = field(default=None, metadata={"help": "cap on each episode's length (default: the env's horizon)"})
    init: str = field(default="fsi", metadata={"help": "episode start: fsi (clip start) or rsi (random frame)"})
    phase: float | None = field(default=None, metadata={"help": "start every episode at this phase (0-1) of the clip instead of by init"})
    seed: int = field(default=0, metadata={"help": "episode k resets with seed + k; pushes use it too"})
    ghost: bool = field(default=True, metadata={"help": "draw the reference motion as a translucent ghost"})
    ghost_offset: tuple = field(default=(0.0, 1.0, 0.0), metadata={"help": "world offset (m) of the ghost from the reference pose; +y puts it beside a character walking along +x"})
    ghost_rgba: tuple = field(default=(0.2, 0.5, 1.0, 0.45), metadata={"help": "ghost colour and opacity"})
    shadows: bool = field(default=False, metadata={"help": "cast shadows (3-4x slower in software OpenGL)"})
    antialias: bool = field(default=False, metadata={"help": "4x multisampling (~2.5x slower in software OpenGL)"})
    camera: CameraConfig = field(default_factory=CameraConfig)
    pushes: PushConfig = field(default_factory=PushConfig)
    label: str = field(default="", metadata={"help": "first caption line (e.g. the policy's source)"})

    def validate(self) -> None:
        if self.width % 2 or self.height % 2 or not (16 <= self.width <= MAX_SIDE and 16 <= self.height <= MAX_SIDE):
            raise SfvError(f"render: --width/--height must be even numbers in [16, {MAX_SIDE}], got {self.width}x{self.height}")
        if self.episodes < 1:
            raise SfvError(f"render: --episodes must be positive, got {self.episodes}")
        if self.seconds is not None and not self.seconds > 0:
            raise SfvError(f"render: --seconds must be positive, got {self.seconds}")
        if self.init not in ("fsi", "rsi"):
            raise SfvError(f"render: --init must be fsi or rsi, got {self.init!r}")
        if self.phase is not None and not 0.0 <= self.phase <= 1.0:
            raise SfvError(f"render: --phase must be in [0, 1], got {self.phase}")
        if self.pushes.count < 0 or not self.pushes.impulse >= 0 or not self.pushes.duration_s > 0:
            raise SfvError("render: --push must be >= 0, --push-impulse >= 0 and --push-duration > 0")


class _Scene:
    """Per-frame drawing: character, ghost, push arrow, camera and caption."""

    def __init__(self, env: ImitationEnv, config: RenderConfig):
        self.env, self.config = env, config
        self.renderer = OffscreenRenderer(env.model, config.width, config.height, shadows=config.shadows, antialias=config.antialias)
        self.ghost = mujoco.MjData(env.model)
        self.ghost_offset = np.asarray(config.ghost_offset, np.float64)
        self.camera = FollowCamera(config.camera)
        self.frame = np.empty((config.height, config.width, 3), np.uint8)
        self._target = np.zeros(2)
        self.root_body = int(env.humanoid.body_ids[0])
        # One text size for the whole video, from the widest lines it can show.
        widest = [config.label or "policy", "episode 99/99  t 99.99 s  phase 0.00", "normalised return 0.000"]
        self.text_scale = text_scale(config.width, config.height, widest)

    def _pose_ghost(self) -> None:
        self.ghost.qpos[:] = self.env.track.qpos[self.env.row]
        self.ghost.qpos[0:3] += self.ghost_offset
        if self.env.ground is not None:
            self.env.ground.lift(0, self.ghost.qpos)  # over the terrain, as the reward sees it
        mujoco.mj_kinematics(self.env.model, self.ghost)

    def draw(self, lines, push_force: np.ndarray | None, snap: bool) -> np.ndarray:
        env = self.env
        if snap and env.ground is not None:
            self.renderer.upload_height_fields()  # the episode's new terrain
        # Follow the midpoint of character and ghost so that both stay in view.
        self._target[:] = env.data.qpos[0:2]
        if self.config.ghost:
            self._pose_ghost()
            self._target += 0.5 * (self.ghost.qpos[0:2] - env.data.qpos[0:2])
        (self.camera.snap if snap else self.camera.follow)(self._target)
        self.renderer.update(env.data, self.camera.camera)
        if self.config.ghost:
            self.renderer.add_tinted_copy(self.ghost, self.config.ghost_rgba)
        if push_force is not None:
            # An arrow pointing into the root along the push.
            tip = env.data.xpos[self.root_body]
            direction = push_force / max(np.linalg.norm(push_force), 1e-9)
            self.renderer.add_arrow(tip - 0.8 * direction, tip - 0.1 * direction, 0.05, (0.92, 0.24, 0.16, 1.0))
        self.renderer.render(self.frame)
        return draw_lines(self.frame, lines, self.text_scale)

    def close(self) -> None:
        self.renderer.close()


def render_policy(policy, env: ImitationEnv, out: str | Path, config: RenderConfig = RenderConfig()) -> dict:
    """Film `config.episodes` deterministic episodes into one MP4 at the control rate."""
    from threadpoolctl import threadpool_limits

    config.validate()
    hz = env.config.control_hz
    scene = _Scene(env, config)
    episodes, frame_seconds = [], 0.0
    # One observation at a time: BLAS threads only add synchronisation (20x slower on a busy 2-core host).
    try:
        with AtomicVideoWriter(out, fps=hz) as video, threadpool_limits(limits=1):
            for episode in range(config.episodes):
                episodes.append(_film_episode(policy, env, scene, video, config, episode))
                frame_seconds += episodes[-1].pop("render_seconds")
            frames = video.frames
    finally:
        scene.close()
    return {
        "video": str(out), "frames": frames, "fps": hz, "width": config.width, "height": config.height,
        "episodes": episodes, "ms_per_frame": 1000.0 * frame_seconds / max(frames, 1),
    }


def _film_episode(policy, env: ImitationEnv, scene: _Scene, video: AtomicVideoWriter, config: RenderConfig, episode: int) -> dict:
    seed = config.seed + episode
    hz = env.config.control_hz
    pushes = None
    push_force, arrow_left = None, 0
    started = time.perf_counter()
    for progress in episode_steps(policy, env, seed, config.init, config.seconds, config.phase):
        if progress.step == 0 and config.pushes.count:
            pushes = PushSchedule(config.pushes, hz, episode_limit(env, config.seconds), np.random.default_rng(seed))
        lines = [
            (config.label or "policy", WHITE),
            (f"episode {episode + 1}/{config.episodes}  t {progress.step / hz:.2f} s  phase {env.phase:.2f}", WHITE),
            (f"normalised return {progress.normalized_return:.3f}", WHITE),
        ]
        # The force acts during the coming step; the arrow stays up 0.4 s so that it can be seen.
        force = apply_push(env.data, scene.root_body, None if progress.done else pushes, progress.step)
        if force is not None:
            push_force, arrow_left = force, int(round(0.4 * hz))
        status = ["fell"] if progress.terminated else []
        if arrow_left > 0:
            status.append(f"push {config.pushes.impulse:.0f} N s")
        if status:
            lines.append(("   ".join(status), PUSH_RED))
        video.append(scene.draw(lines, push_force if arrow_left > 0 else None, snap=progress.step == 0))
        arrow_left -= 1
    seconds = time.perf_counter() - started
    return {
        "seed": seed, "steps": progress.step, "seconds": progress.step / hz, "fell": progress.terminated,
        "normalized_return": progress.normalized_return,
        "pushes": 0 if pushes is None else int(len(pushes.starts)),
        "render_seconds": seconds,
    }
