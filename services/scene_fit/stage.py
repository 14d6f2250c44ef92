"""A scene fit from a root-free motion and a scene file: windows -> SLSQP fit -> final rollout.

The pipeline (`sfv pipeline VIDEO --camera moving --scene boxes.yaml`) runs it after the
reconstruction; `bench/scripts/scene_fit.py` runs it on a synthetic box clip. `check_inputs` reads and
checks the motion and the scene before anything is trained, so that bad input is one line.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from actors.motion.formats.io import load_motion
from services.scene_fit import scene_contract
from services.scene_fit.windows import MAX_OBJECTS, Window, proportional_contact_frames, split_windows
from services.training.config import TrainConfig

log = logging.getLogger("sfv.scene_fit")


@dataclass
class SceneFitOutcome:
    summary: dict  # what scene_fit.json holds, plus the written files
    simulated: object  # final_rollout.SimulatedRun in the fitted scene
    runs: list  # sequence.WindowRun
    scene_vector: np.ndarray | None  # the fitted e (None: no scene)
    coverage: object = None  # coverage.Coverage of the clip by `simulated`
    clip: object = None  # the root-free motion the windows were cut from


def check_inputs(motion_path: str, scene_path: str | None, env_config):
    """(motion, scene or None), or the actors' one-line errors: a box out of its domain or over
    the start pose (the scene loader), no contacts or orientation hint (the movingcam mode's
    targets, built with an env of the clip)."""
    motion = load_motion(str(motion_path))
    scene = None if scene_path is None else scene_contract.load_scene(scene_path, motion)
    scene_contract.check_env(motion, env_config)
    return motion, scene


def plan_windows(num_frames: int, scene, max_objects: int = MAX_OBJECTS) -> list[Window]:
    """The clip's windows; box contacts placed by the boxes' order along the heading."""
    if scene is None:
        return split_windows(num_frames, [], max_objects)
    alongs = np.array([box.along for box in scene.boxes])
    frames = proportional_contact_frames(alongs, num_frames)
    return split_windows(num_frames, [(int(f), i) for i, f in enumerate(frames)], max_objects)


def run_scene_fit(motion_path: str, scene_path: str | None, out: Path, base: TrainConfig,
                  max_objects: int = MAX_OBJECTS, rollouts: int = 8, progress: bool = True,
                  fit_starts: int = 4) -> SceneFitOutcome:
    """Train the windows (resumable), fit the scene, roll out in it (Ray tasks when Ray is up:
    `fit_tasks.py`), write the outputs."""
    from services.scene_fit.fit_tasks import run_fit_stages
    from services.scene_fit.outputs import write_outputs
    from services.scene_fit.sequence import train_windows

    clip, scene = check_inputs(motion_path, scene_path, base.env)
    windows = plan_windows(clip.num_frames, scene, max_objects)
    runs = train_windows(out, windows, clip, scene, base, rollouts=rollouts, progress=progress)
    summary: dict = {"motion": str(motion_path), "scene_file": None if scene_path is None else str(scene_path),
                     "windows": [w.to_dict() for w in windows], "samples_per_window": base.samples}
    reference_contacts = clip.extras.get("contacts")
    stages = run_fit_stages(runs, scene, seed=base.seed, starts=fit_starts)
    e = None if stages.fit is None else stages.fit.scene
    if stages.fit is not None:
        summary["fit"] = stages.fit.to_dict()
        summary["initial_scene"] = scene_contract.scene_vector(scene).tolist()
        summary["initial_scene_scores"] = stages.initial.scores(reference_contacts)  # Table 2's "fixed scene"
    simulated = stages.simulated
    summary["scores"] = simulated.scores(reference_contacts)
    from services.scene_fit.coverage import coverage

    cover = coverage(simulated, windows, clip.frame_times)
    summary["coverage"] = cover.to_dict()
    log.info("%s", cover.line)
    from actors.character.humanoid3d import Humanoid
    from actors.character.state import StateLayout

    motion = simulated.motion(f"{clip.name}-simulated", StateLayout(Humanoid()))
    fitted = None if scene is None else scene_contract.scene_with(scene, e)
    summary["files"] = write_outputs(out, motion, fitted, summary)
    return SceneFitOutcome(summary, simulated, runs, e, cover, clip)
