"""The sfv mode's settings: its reward and its tracking-deviation termination.

They sit under `EnvConfig.sfv` (flags `--env.sfv.reward.*`, `--env.sfv.tracking-termination-m`)
beside the movingcam mode's `EnvConfig.movingcam`: each mode owns what only it reads."""
from __future__ import annotations

from dataclasses import dataclass, field

from actors.envs.modes.sfv.reward import RewardConfig


@dataclass(frozen=True)
class SfvConfig:
    reward: RewardConfig = field(default_factory=RewardConfig, metadata={"help": "the sfv mode's reward weights and scales"})
    tracking_termination_m: float = field(default=1.0, metadata={"help": "also end an episode (as a fall) when an end effector or the root is farther than this (m) from the reference's (MimicKit: 1.0); 0: off; evaluation never uses it (measured: docs/training.md)"})

    def __post_init__(self):
        if isinstance(self.reward, dict):  # from a saved run config
            object.__setattr__(self, "reward", RewardConfig(**self.reward))
        if not self.tracking_termination_m >= 0:
            raise ValueError(f"tracking_termination_m must be >= 0, got {self.tracking_termination_m}")
