"""What the motor module's decoder does on its own prior's latents (NPMP, 004 §3.3-3.4).

    python bench/scripts/npmp_prior_samples.py --module MODULE [--episodes 32] [--result bench/results/npmp/prior_samples.json]

The AR(1) prior p(z_t | z_t-1) = N(alpha z_t-1, (1 - alpha^2) sigma^2) is what a task policy's
exploration starts from: the decoder driven by samples of it should move like the experts,
and keep its feet, without any task policy. The check rolls the frozen decoder out from random
walk frames (the task envs' starts, 10 s episodes, the task envs' fall rule) under three latent
streams with the same per-step marginal N(0, sigma^2):
- `prior`: the module's AR(1) chain (alpha from its config), temporally correlated;
- `white`: independent draws every step (alpha = 0), the same marginal without the correlation;
- `zero`: z = 0 throughout, the prior's mean.
Per stream: fall rate, episode seconds, the motion distance to the nearest mocap window
(`services/tasks/motion_likeness.py`: 0 for the clips, .37 standing still) and the pose log-density of every pose held under the
expert clips' pose prior (`services/tasks/pose_prior.py`, higher is more human-like; the clips'
own frames score `pose_log_density_experts`).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # run from a checkout without installing

from learner.motor_module import prior_sample  # noqa: E402  the module's own AR(1) step (numpy arrays too)

RESULT = Path(__file__).resolve().parents[2] / "bench" / "results" / "npmp" / "prior_samples.json"
LATENT_SCALE = 4.0  # the task action box maps to +-4 sigma, so prior draws are (almost) never clipped


class LatentStream:
    """`mean(obs)` -> the next latent of each env as a task action (z / LATENT_SCALE)."""

    def __init__(self, num_envs: int, latent_dim: int, alpha: float, sigma: float, seed: int, zero: bool = False):
        self.rng = np.random.default_rng(seed)
        self.alpha, self.sigma, self.zero = alpha, sigma, zero
        self.z = np.zeros((num_envs, latent_dim)) if zero else sigma * self.rng.standard_normal((num_envs, latent_dim))

    def mean(self, obs: np.ndarray) -> np.ndarray:
        action = (self.z / LATENT_SCALE).astype(np.float32)
        if not self.zero:
            self.z = prior_sample(self.z, self.alpha, self.sigma, self.rng.standard_normal(self.z.shape))
        return action


def run_stream(module: str, name: str, alpha: float, sigma: float, latent_dim: int, episodes: int, seed: int, prior,
               library=None) -> dict:
    from actors.envs.tasks.config import TaskEnvConfig
    from actors.envs.tasks.vector_task_env import VectorTaskEnv
    from services.tasks.evaluation import run_episodes

    config = TaskEnvConfig(task="go_to", action="latent", module=module, latent_scale=LATENT_SCALE)
    env = VectorTaskEnv(config, episodes, seed=seed)
    stream = LatentStream(episodes, latent_dim, alpha, sigma, seed + 1, zero=name == "zero")
    per_episode, sequences = run_episodes(env, stream)  # each episode's (T, 28) poses
    poses = np.concatenate(sequences)
    return {"alpha": alpha if name != "zero" else None, "fall_rate": float(per_episode["fell"].mean()),
            "episode_seconds": float(per_episode["lengths"].mean() / config.control_hz),
            "pose_log_density": float(prior.log_density(poses).mean()) if len(poses) else None,
            **({"motion_distance": library.score(sequences)} if library is not None else {})}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--module", required=True, help="motor module directory (sfv distill --out)")
    parser.add_argument("--episodes", type=int, default=32)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--result", type=Path, default=RESULT)
    args = parser.parse_args(argv)

    from threadpoolctl import threadpool_limits

    from learner.atomic_io import atomic_write_json
    from services.tasks.pose_prior import PosePrior, clip_poses

    import json

    from learner.motor_config import MotorModuleConfig
    from learner.motor_decoder import module_path

    # the module's settings from its config.json (a shipped module has no module.pt)
    settings = MotorModuleConfig.from_dict(json.loads((module_path(args.module) / "config.json").read_text())["module"])
    alpha, sigma, dim = float(settings.alpha), float(settings.prior_std), int(settings.latent_dim)
    from services.tasks.motion_likeness import MotionLibrary

    prior, library = PosePrior.fit(), MotionLibrary.fit()
    started = time.perf_counter()
    with threadpool_limits(1, user_api="blas"):
        streams = {name: run_stream(args.module, name, a, sigma, dim, args.episodes, args.seed, prior, library)
                   for name, a in (("prior", alpha), ("white", 0.0), ("zero", 0.0))}
    experts = np.concatenate([prior.log_density(clip_poses(clip)) for clip in prior.clips])
    record = {"what": "the frozen decoder driven by latent streams alone, from random walk frames, 10 s episodes",
              "module": str(args.module), "episodes": args.episodes, "latent_dim": dim, "prior_std": sigma,
              "streams": streams, "pose_log_density_experts": float(experts.mean()),
              "motion_distance_lines": library.reference_distances(), "wall_s": time.perf_counter() - started}
    atomic_write_json(args.result, record, sort_keys=False)
    for name, row in streams.items():
        print(f"{name:6s} falls {row['fall_rate']:.2f}  seconds {row['episode_seconds']:.1f}  pose log-density {row['pose_log_density']:.1f}"
              f"  motion distance {row['motion_distance']:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
