"""`sfv task eval`: deterministic episodes of a task policy and what they achieved.

E episodes run side by side in one `VectorTaskEnv` (one batched policy forward per step), each
env's first episode counted; the policy acts with its mean. Figures: success_rate (episodes
that reached their first target within the horizon), time_to_target_s (mean seconds to the
first target over those that did), fall_rate, targets_per_episode, return_mean,
episode_seconds, and pose_log_density: the mean log-density of every pose the character held
under the expert clips' pose prior (`pose_prior.py`; higher is more human-like), beside
pose_log_density_experts, the same score of the clips' own frames (the human reference); and
motion_distance, the mean distance of each third of a second of movement to its nearest mocap
window (`motion_likeness.py`; lower is more human-like), beside motion_distance_lines (a clip
held out of the library; standing still). The pose density ranks standing above the mocap; the
motion distance does not.

On a slope (`--env.slope`) the figures are also split by the grade along each episode's first
task direction (`by_direction`: up where it is above half the slope's grade, down below minus
half, across between; SFV Fig. 8 pushes the box up and down a 15 % slope): episodes, success
and fall rates of each.
"""
from __future__ import annotations

import mujoco
import numpy as np

from actors.envs.tasks.vector_task_env import VectorTaskEnv
from learner.policy import NumpyPolicy
from services.tasks.motion_likeness import MotionLibrary
from services.tasks.pose_prior import PosePrior, clip_poses


def run_episodes(env: VectorTaskEnv, policy: NumpyPolicy, after_reset=None) -> tuple[dict[str, np.ndarray], list[np.ndarray]]:
    """Each env's first episode from `env.reset()`: (per-episode arrays, each episode's (T, 28)
    poses). `after_reset(env)` may place the episodes' first targets (it returns the observations)."""
    n = env.num_envs
    first: dict[str, list] = {}
    done = np.zeros(n, bool)
    poses: list[list[np.ndarray]] = [[] for _ in range(n)]
    obs = env.reset()
    if after_reset is not None:
        obs = after_reset(env)
    env.episodes.drain()
    while not done.all():
        obs, _, terminated, truncated, _ = env.step(policy.mean(obs))
        ended = terminated | truncated
        log = env.episodes.drain()  # entries in env order of this step's ended envs
        for entry, i in enumerate(np.flatnonzero(ended)):
            if not done[i]:
                for key, values in log.items():
                    first.setdefault(key, [None] * n)[i] = values[entry]
        for i in np.flatnonzero(~done & ~ended):  # the pose after this step (ended envs were reset already)
            data = env.datas[i]
            mujoco.mj_transmission(env.model, data)
            poses[i].append(data.actuator_length.copy())
        done |= ended
    sequences = [np.asarray(p).reshape(-1, env.model.nu) for p in poses]
    return {k: np.asarray(v) for k, v in first.items()}, sequences


def evaluate_task(env_config, weights: dict | None, episodes: int = 32, seed: int = 0, prior: PosePrior | None = None,
                  library: MotionLibrary | None = None, policy=None) -> dict:
    """The figures of the module docstring for `weights` (a task run's policy), or for `policy`
    (anything with `mean(obs)`: the chance line's z = 0 of `bench/scripts/npmp_tasks.py`)."""
    from threadpoolctl import threadpool_limits

    prior = prior or PosePrior.fit()
    library = library or MotionLibrary.fit()
    env = VectorTaskEnv(env_config, episodes, seed=seed)
    policy = policy or NumpyPolicy(weights, max_batch=episodes)
    with threadpool_limits(1, user_api="blas"):
        per_episode, sequences = run_episodes(env, policy)
    poses = np.concatenate(sequences)
    successes = per_episode["successes"].astype(bool)
    times = per_episode["first_success_s"].astype(float)
    experts = np.concatenate([prior.log_density(clip_poses(clip)) for clip in prior.clips])
    record = {
        "episodes": int(episodes),
        "success_rate": float(successes.mean()),
        "time_to_target_s": float(np.nanmean(times)) if successes.any() else None,
        "fall_rate": float(per_episode["fell"].astype(bool).mean()),
        "targets_per_episode": float(per_episode["targets_reached"].mean()),
        "return_mean": float(per_episode["returns"].mean()),
        "episode_seconds": float(per_episode["lengths"].mean() / env_config.control_hz),
        "pose_log_density": float(prior.log_density(poses).mean()) if len(poses) else None,
        "pose_log_density_experts": float(experts.mean()),
        "pose_prior": f"mixture of one Gaussian per clip ({len(prior.clips)} humanoid3d clips)",
        "motion_distance": library.score(sequences),
        "motion_distance_lines": library.reference_distances(),
    }
    if env_config.slope > 0:
        record["by_direction"] = split_by_direction(per_episode, env_config.slope)
    if env_config.task == "push_box_phased":
        record["by_start_phase"] = split_by_start_phase(per_episode)
    return record


def split_by_start_phase(per_episode: dict[str, np.ndarray]) -> dict[str, dict]:
    """The phased push-box's episodes by the phase they started in (004 Fig. 8B): episodes, the box
    reached (the first phase done, for those that started before it), success (a box delivered), falls."""
    phase = per_episode["start_phase"].astype(int)
    out = {}
    for name, mask in (("go_to_the_box", phase == 0), ("push", phase == 1)):
        n = int(mask.sum())
        out[name] = {"episodes": n,
                     "box_reached_rate": float(per_episode["first_phase_done"][mask].astype(bool).mean()) if n and name == "go_to_the_box" else None,
                     "success_rate": float(per_episode["successes"][mask].astype(bool).mean()) if n else None,
                     "fall_rate": float(per_episode["fell"][mask].astype(bool).mean()) if n else None}
    return out


def split_by_direction(per_episode: dict[str, np.ndarray], slope: float) -> dict[str, dict]:
    """Episodes, success and fall rates of the episodes whose first task direction goes up,
    down or across the slope (its grade along the direction against +-slope / 2)."""
    along = per_episode["grade_along"].astype(float)
    groups = {"up": along > slope / 2, "down": along < -slope / 2}
    groups["across"] = ~(groups["up"] | groups["down"])
    out = {}
    for name, mask in groups.items():
        n = int(mask.sum())
        out[name] = {"episodes": n,
                     "success_rate": float(per_episode["successes"][mask].astype(bool).mean()) if n else None,
                     "fall_rate": float(per_episode["fell"][mask].astype(bool).mean()) if n else None}
    return out
