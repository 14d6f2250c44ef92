"""The one place scene fitting meets the scene boxes and the movingcam env mode (issue 15).

What this package relies on, and from where:
- `actors.arenas.scene`: `load_scene(path, motion)` (every fault one `SceneError` line, a box outside
  its domain or over the start pose included), `Scene.vector()` = [along, height] per box,
  `Scene.bounds()` (low, high), `Scene.normalise(e)` (to [-1, 1] over the domain),
  `Scene.with_vector(e)`, `Box`, `SceneFrame.of_motion` (the scene's axes: the clip's first frame).
- the env: the scene vector, normalised, is the observation's LAST `vector_dim` entries; the
  arena's `set_scene(model, e)` moves the boxes at runtime; training draws e per episode.
- `EnvConfig.mode = "movingcam"` (002's tracking reward and termination, root left to physics).
Everything here that names one of those is the merge's one line to change if it differs.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from learner.errors import SfvError
from services.scene_fit.fit import SceneObs

SCENE_ENV_FIELD = "scene"  # EnvConfig's field holding the scene file (actors' box arena)
# EnvConfig's switch of the scene loader's start-pose check. A window after the first starts
# where the character meets a box (by construction), which that check of the user's file
# refuses; the user's file was checked against the clip's first frame already.
START_CHECK_FIELD = "scene_check_start_pose"
MOVINGCAM_MODE = "movingcam"


def _scene_module():
    try:
        from actors.arenas import scene
    except ImportError:
        raise SfvError("--scene needs the scene boxes (actors/arenas/scene.py, issue 15), which this build lacks") from None
    return scene


def load_scene(path, motion=None):
    """The scene file, checked by its own loader (domains; with `motion`, the start pose)."""
    return _scene_module().load_scene(Path(path), motion)


def scene_bounds(scene) -> np.ndarray:
    """(D, 2) [min, max] of each scene-vector entry: SLSQP's bounds."""
    low, high = scene.bounds()
    return np.stack([low, high], axis=1)


def scene_obs(scene) -> SceneObs:
    """Where and how e sits in the observation: normalise(e) = 2 (e - low) / (high - low) - 1,
    written as (e - offset) / scale for the fit's autograd (`Scene.normalise`'s affine map;
    a domain of one point gets scale inf, i.e. entry 0, as there)."""
    low, high = scene.bounds()
    span = high - low
    return SceneObs(offset=(low + high) / 2.0, scale=np.where(span > 0, span / 2.0, np.inf))


def scene_vector(scene) -> np.ndarray:
    return np.asarray(scene.vector(), np.float64)


def scene_with(scene, e):
    return scene.with_vector(np.asarray(e, np.float64))


def write_scene_yaml(scene, path: Path) -> Path:
    """A scene file `load_scene` reads back (atomic)."""
    import yaml

    from learner.atomic_io import atomic_write_text

    boxes = []
    for box in scene.boxes:
        boxes.append({"name": box.name, "along": float(box.along), "lateral": float(box.lateral),
                      "height": float(box.height), "size": [float(s) for s in box.size],
                      "domain": {"along": [float(v) for v in box.along_domain],
                                 "height": [float(v) for v in box.height_domain]}})
    return atomic_write_text(path, yaml.safe_dump({"boxes": boxes}, sort_keys=False))


def movingcam_env(env_config, scene_path: str | None):
    """The env config of a moving-camera window: 002's tracking mode, in the scene's boxes."""
    fields = {f.name for f in dataclasses.fields(env_config)}
    if "mode" not in fields:
        raise SfvError("--camera moving needs the movingcam env mode (EnvConfig.mode, issue 15), which this build lacks")
    env_config = dataclasses.replace(env_config, mode=MOVINGCAM_MODE)
    return env_config if scene_path is None else with_scene_file(env_config, scene_path)


def with_scene_file(env_config, scene_path, check_start_pose: bool = True):
    """The env config with its boxes from `scene_path` (drawn per episode in training)."""
    fields = {f.name for f in dataclasses.fields(env_config)}
    if SCENE_ENV_FIELD not in fields:
        raise SfvError("--scene needs the box arena in the env (EnvConfig.scene, issue 15), which this build lacks")
    changes = {SCENE_ENV_FIELD: str(scene_path)}
    if START_CHECK_FIELD in fields:
        changes[START_CHECK_FIELD] = check_start_pose
    return dataclasses.replace(env_config, **changes)


def set_env_scene(env, e) -> None:
    """Put env's boxes at scene vector e for what follows (the rollouts, the final run): the
    env's own setter when it has one (it also fixes the observed e), else the arena's."""
    if hasattr(env, "set_scene"):
        env.set_scene(np.asarray(e, np.float64))
        return
    arena = getattr(env.humanoid, "arena", None)
    if not hasattr(arena, "set_scene"):
        raise SfvError("scene fit: this env has no boxes to place")
    arena.set_scene(env.model, np.asarray(e, np.float64))


def check_env(motion, env_config) -> None:
    """Build one env of `motion` with `env_config`: the movingcam mode checks the motion's
    contacts and orientation hint, the box arena the scene file, each with its one-line error,
    before anything is trained."""
    from actors.envs.imitation_env import ImitationEnv

    ImitationEnv(motion, env_config)
