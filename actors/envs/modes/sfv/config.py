"""The sfv mode's settings: its reward and its tracking-deviation termination.

They sit under `EnvConfig.sfv` (flags `--env.sfv.reward.*`, `--env.sfv.tracking-termination-m`)
beside the movingcam mode's `EnvConfig.movingcam`: each mode owns what only it reads."""
from __future__ import annotations

from dataclasses import dataclass, field

from actors.envs.modes.sfv.reward import RewardConfig


@dataclass(frozen=True)
class SfvConfig:
    reward: RewardConfig = field(default_factory=RewardConfig, metadata={"help": "the sfv mode's reward weights and scales"})
    tracking_termination_m: float = field(default=1.0, metadata={"help": "also end the episode (as a fall) when an end effector or the root is farther than this (m) from the reference's (MimicKit pose_termination at 1.0 m, PHC/ProtoMotions 0.25-0.5 m; actors/envs/modes/sfv/tracking_termination.py); 0: off. Never used by evaluation. sfv eval at 1.0 m / off: walk .981 / .969 at 2 M, run .906 at 3 M / .855 at 7 M, getup_faceup .934 / .865, getup_facedown .944 / .887, crawl .941 / .935, roll .706 / .382 (0.5 m: worse)"})

    def __post_init__(self):
        if isinstance(self.reward, dict):  # from a saved run config
            object.__setattr__(self, "reward", RewardConfig(**self.reward))
        if not self.tracking_termination_m >= 0:
            raise ValueError(f"tracking_termination_m must be >= 0, got {self.tracking_termination_m}")
