"""The windows' policies trained in order, each from the states the previous one reached (002 §5.3).

Directory of a scene fit (`out`):

    windows/w<n>/motion.npz     the window's frames of the clip (`window_motion.py`)
    windows/w<n>/scene.yaml     the scene in the window's frame (its first frame's root), when there is one
    windows/w<n>/handover.npz   states of window n-1's policy at this window's first frame (n > 0)
    windows/w<n>/train/         the window's `sfv train` run directory (Trainer, resumable)
    windows/w<n>/rollouts.npz   its policy's rollouts in the given scene (`handover.py`)
    windows/w<n>/window.json    written last: the window is done

Resumable: a finished window (window.json) is skipped; an interrupted one continues from its
newest checkpoint (`--resume`), and its rollouts are taken again.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from actors.motion.reference_motion import ReferenceMotion
from actors.motion.formats.io import save_motion
from learner.atomic_io import atomic_write_json
from services.scene_fit import scene_contract
from services.scene_fit.handover import WindowRollouts, roll_window
from services.scene_fit.window_motion import control_steps, window_motion
from services.scene_fit.window_scene import window_scene
from services.scene_fit.windows import Window
from services.training.config import TrainConfig

log = logging.getLogger("sfv.scene_fit")
DONE_FILE = "window.json"


@dataclass
class WindowRun:
    """Where one window's files are, and its scene-vector offset from the clip's."""

    window: Window
    directory: Path
    scene_shift: np.ndarray | None  # e_window = e_clip + scene_shift (None: no scene)

    @property
    def motion_path(self) -> Path:
        return self.directory / "motion.npz"

    @property
    def scene_path(self) -> Path | None:
        return None if self.scene_shift is None else self.directory / "scene.yaml"

    @property
    def train_dir(self) -> Path:
        return self.directory / "train"

    @property
    def rollouts_path(self) -> Path:
        return self.directory / "rollouts.npz"

    @property
    def done(self) -> bool:
        return (self.directory / DONE_FILE).is_file()

    def rollouts(self) -> WindowRollouts:
        return WindowRollouts.load(self.rollouts_path)

    def window_e(self, e) -> np.ndarray:
        return np.asarray(e, np.float64) + self.scene_shift


def window_config(base: TrainConfig, run: WindowRun, handover_path: Path | None) -> TrainConfig:
    """`base` (samples, workers, PPO, env) for one window: its motion, run directory, starts, scene."""
    config = TrainConfig.from_dict(base.to_dict())
    config.motion, config.out, config.job_id = str(run.motion_path), str(run.train_dir), None
    config.handover_states = None if handover_path is None else str(handover_path)
    if run.scene_path is not None:
        config.env = scene_contract.with_scene_file(config.env, run.scene_path, check_start_pose=run.window.index == 0)
    return config


def prepare_window(run: WindowRun, clip: ReferenceMotion, scene, previous: WindowRollouts | None) -> tuple[ReferenceMotion, Path | None]:
    """Write the window's motion, scene and hand-over states; returns its motion and hand-over file."""
    run.directory.mkdir(parents=True, exist_ok=True)
    root_xy = None if previous is None else previous.mean_root_xy
    motion = window_motion(clip, run.window, root_xy)
    save_motion(motion, run.motion_path)
    if scene is not None:
        placed, run.scene_shift = window_scene(scene, clip, motion)
        scene_contract.write_scene_yaml(placed, run.scene_path)
    if previous is None:
        return motion, None
    path = run.directory / "handover.npz"
    previous.save(path)
    return motion, path


def train_window(run: WindowRun, clip: ReferenceMotion, scene, initial_e, base: TrainConfig,
                 previous: WindowRollouts | None, rollouts: int, progress: bool) -> WindowRollouts:
    """Train one window (resuming a started run) and roll its policy out in the initial scene."""
    from actors.envs.imitation_env import ImitationEnv
    from services.training.driver import Trainer
    from services.training.run_dir import checkpoint_files, load_run

    motion, handover_path = prepare_window(run, clip, scene, previous)
    config = window_config(base, run, handover_path)
    resume = bool(checkpoint_files(run.train_dir))
    log.info("window %d: frames %d..%d, %s", run.window.index, run.window.start, run.window.end,
             "resuming" if resume else "training")
    with Trainer(config, resume=resume, progress=progress) as trainer:
        record = trainer.run()
    from learner.policy import NumpyPolicy

    trained, weights = load_run(run.train_dir)
    env = ImitationEnv(motion, trained.env)
    if scene is not None:
        scene_contract.set_env_scene(env, run.window_e(initial_e))
    handover = None if previous is None else previous.handover()
    steps = control_steps(run.window, motion, trained.env.control_hz)
    result = roll_window(NumpyPolicy(weights, max_batch=1), env, steps, rollouts,
                         seed=base.seed + 7919 * (run.window.index + 1), handover=handover)
    result.save(run.rollouts_path)
    atomic_write_json(run.directory / DONE_FILE, {
        "window": run.window.to_dict(), "samples": record.get("samples", trainer.samples),
        "normalized_return": record.get("normalized_return"), "rollouts": int(len(result.reached)),
        "reached_control_end": int(result.reached.sum()),
        "scene_shift": None if run.scene_shift is None else run.scene_shift.tolist()}, sort_keys=True)
    return result


def window_runs(out: Path, windows: list[Window]) -> list[WindowRun]:
    return [WindowRun(w, Path(out) / "windows" / f"w{w.index}", None) for w in windows]


def train_windows(out: Path, windows: list[Window], clip: ReferenceMotion, scene, base: TrainConfig,
                  rollouts: int = 8, progress: bool = True) -> list[WindowRun]:
    """Every window in order; a finished one is read back, not trained again."""
    runs = window_runs(out, windows)
    initial_e = None if scene is None else scene_contract.scene_vector(scene)
    previous: WindowRollouts | None = None
    for run in runs:
        if run.done:
            if scene is not None:
                run.scene_shift = np.asarray(_read_json(run.directory / DONE_FILE)["scene_shift"], np.float64)
            previous = run.rollouts()
            log.info("window %d: done already", run.window.index)
            continue
        previous = train_window(run, clip, scene, initial_e, base, previous, rollouts, progress)
    return runs


def _read_json(path: Path) -> dict:
    import json

    return json.loads(Path(path).read_text())
