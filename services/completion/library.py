"""The library of skills {(q_t^i), pi^i}: trained runs, each with its policy, its imitation
env and its reference poses on the control-step grid.

The reference is compared on the env's `ReferenceTrack` rows (the rows an episode can start
from: one pass of the clip), so the chosen row is exactly where the simulation starts.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from actors.envs.imitation_env import ImitationEnv
from actors.motion.formats.io import load_motion
from learner.errors import SfvError
from learner.policy import NumpyPolicy
from services.training.run_dir import CONFIG_FILE


@dataclass
class Skill:
    run_dir: Path
    policy: NumpyPolicy
    env: ImitationEnv
    root_rot: np.ndarray  # (N, 4) reference root rotation at start rows 0..N-1
    joint_rot: np.ndarray  # (N, 12, 4) reference local joint rotations at those rows

    @property
    def motion_name(self) -> str:
        return self.env.motion.name


def check_run_dirs(run_dirs) -> list[Path]:
    """Cheap up-front check (before any model loads) that each path is a run directory."""
    if not run_dirs:
        raise SfvError("complete: --library needs at least one run directory")
    paths = [Path(p) for p in run_dirs]
    for path in paths:
        if not (path / CONFIG_FILE).is_file():
            raise SfvError(f"{path}: not a run directory (no {CONFIG_FILE})")
    return paths


def reference_rotations(env: ImitationEnv) -> tuple[np.ndarray, np.ndarray]:
    """Root and local joint rotations of the reference at every start row of the env's track."""
    rows = env.track.start_steps
    qpos = env.track.qpos[:rows]
    joint_rot = np.empty((rows, env.layout.num_joints, 4))
    for row in range(rows):
        env.layout.joint_quats_from_qpos(qpos[row], joint_rot[row])
    return qpos[:, 3:7].copy(), joint_rot


def load_skill(run_dir: str | Path) -> Skill:
    from services.training.run_dir import load_run

    run_dir = Path(run_dir)
    config, weights = load_run(run_dir)
    env = ImitationEnv(load_motion(config.motion), config.env)
    root_rot, joint_rot = reference_rotations(env)
    return Skill(run_dir, NumpyPolicy(weights, max_batch=1), env, root_rot, joint_rot)


def load_library(run_dirs) -> list[Skill]:
    return [load_skill(path) for path in check_run_dirs(run_dirs)]
