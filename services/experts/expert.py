"""An expert: the policy that tracks one clip, with the env it was trained in (004 §3.2).

`Expert` wraps a trained run directory; `MirroredExpert` (`mirrored_expert.py`) has the same
interface for `<clip>_mirror`; `library.load_expert(DIR, clip)` finds either in an experts
directory. Consumers (the table, the dataset recorder) need only:
- `expert.motion`: the clip's motion name (`deepmimic:walk`, `deepmimic:walk_mirror`);
- `expert.env_config`: the `EnvConfig` the expert acts in (the training run's);
- `expert.make_env()`: an `ImitationEnv` on that clip with that config (its character's body:
  `env_config.character`, humanoid3d or g1, a humanoid clip retargeted onto a robot at load);
- `expert.act(obs)`: the mean actions (B, act_dim: 28 humanoid3d, 29 g1) float32 for a batch of that env's observations
  (B, obs_dim); `mean` is the same call (what `evaluate_policy` looks for).
Action noise for robustness (004 §3.2: sigma = .1 on [-1, 1] actions) is the caller's: add it
to `act`'s means. PPO already trains every expert with that noise, its fixed Gaussian action
std (`learner/config.py` `action_std` = 0.1 in the same normalised units).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.character.characters import character_named
from actors.motion.character_reference import load_reference


class Expert:
    def __init__(self, policy, env_config: EnvConfig, motion: str, name: str):
        self.policy = policy  # NumpyPolicy-like: mean(obs (B, obs_dim)) -> (B, act_dim)
        self.env_config = env_config
        self.motion = motion
        self.name = name

    @classmethod
    def from_run(cls, run_dir: str | Path, max_batch: int = 64) -> "Expert":
        from learner.policy import NumpyPolicy
        from services.training.run_dir import load_run

        config, weights = load_run(run_dir)
        return cls(NumpyPolicy(weights, max_batch=max_batch), config.env, config.motion, Path(run_dir).name)

    def make_env(self) -> ImitationEnv:
        return ImitationEnv(self.reference(), self.env_config)

    def reference(self):
        """The clip in the pose space of the expert's character."""
        return load_reference(self.motion, character_named(self.env_config.character))

    def act(self, obs: np.ndarray) -> np.ndarray:
        """Mean actions (B, act_dim), a fresh float32 array."""
        return np.array(self.policy.mean(np.asarray(obs, dtype=np.float32)), dtype=np.float32)

    mean = act

