"""The sfv mode: DeepMimic/SFV imitation of the whole reference, root path included.

Reward: DeepMimic's imitation reward (`actors/envs/modes/sfv/reward.py`). Termination: the
tracking deviation (`tracking_termination.py`, `EnvConfig.sfv.tracking_termination_m`; 0: off) on
top of the core's fall rule. Observation: the core's features with the reference roots
ahead (`EnvConfig.reference_obs_steps`, written by the core's `ReferenceObservation`, since
the mode tracks the root); nothing else."""
from __future__ import annotations

import numpy as np

from actors.envs.modes.sfv.reward import TERM_NAMES, ImitationReward
from actors.envs.modes.sfv.tracking_termination import TrackingTermination


class SfvMode:
    name = "sfv"
    term_names = TERM_NAMES
    tracks_root = True
    characters = None  # any body: the reward reads the character's joints and weights
    captures = ()

    def __init__(self, config, track, humanoid, batch: int):
        self.reward = ImitationReward(config.sfv.reward, humanoid)
        self.max_reward = config.sfv.reward.max_reward
        self.tracking_termination = TrackingTermination(config.sfv.tracking_termination_m, batch)
        self.terminated = np.zeros(batch, dtype=bool)

    @staticmethod
    def step_reward_bound(config) -> float:
        """The most one control step earns with `config` (before the env is built)."""
        return config.sfv.reward.max_reward

    def rewards(self, rows, features, sim, ref, terms, check_termination):
        rewards = self.reward.batch(sim, ref, terms)
        if check_termination and self.tracking_termination.active:  # evaluation turns it off
            self.terminated[:] = self.tracking_termination(sim, ref)
        else:
            self.terminated[:] = False
        return rewards

    def reward_one(self, data, row_buf, features, sim, ref, terms) -> float:
        return self.reward(sim, ref, terms[0])

    def observe(self, rows, out) -> None:
        pass

    def set_obstacles(self, geom_ids) -> None:
        pass
