"""A window's value function V_n(s, e), read from its run's newest checkpoint (002 §5.3).

The learner's own value network and observation normaliser (torch), so that the scene fit
gets exact gradients dV/de by autograd; the scene vector reaches V as the observation's last
entries (`scene_contract.put_scene`).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from learner.checkpoint import load_checkpoint
from learner.errors import SfvError
from learner.networks import ObservationNormalizer, ValueNetwork
from learner.ppo import PPOLearner
from services.training.run_dir import checkpoint_files


class ValueFunction:
    """V(obs) of a value network and its normaliser: numpy in, numpy out, or torch with grad."""

    def __init__(self, value: ValueNetwork, normalizer: ObservationNormalizer):
        self.value, self.normalizer = value.eval(), normalizer.eval()
        for p in list(value.parameters()) + list(normalizer.parameters()):
            p.requires_grad_(False)

    @classmethod
    def from_run(cls, run_dir: str | Path) -> "ValueFunction":
        checkpoints = checkpoint_files(Path(run_dir))
        if not checkpoints:
            raise SfvError(f"{run_dir}: no checkpoint, so no value function to fit the scene with")
        state = load_checkpoint(checkpoints[-1])["learner"]
        learner = PPOLearner(int(state["obs_dim"]), int(state["act_dim"]))
        learner.load_state_dict(state)  # the policy and optimiser come along; only V and the normaliser are kept
        return cls(learner.value, learner.normalizer)

    def torch_values(self, obs: torch.Tensor) -> torch.Tensor:
        return self.value(self.normalizer(obs))

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            return self.torch_values(torch.as_tensor(np.asarray(obs, np.float32))).double().numpy()
