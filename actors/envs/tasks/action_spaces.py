"""Two action spaces behind one interface (NPMP 004 §3.4 against a from-scratch baseline).

- `LatentActions`: the task policy outputs z (scaled from its [-1, 1] box by `latent_scale`);
  the frozen decoder turns (proprioception, z) into PD targets every control step, for all
  envs of a worker in one batched numpy call. 004 feeds the high-level action straight into
  the low-level module; the scale is ours, because this PPO has a fixed action std in
  [-1, 1] units and penalises means beyond the box.
- `JointActions`: PD targets directly, absolute exp-map targets as in `actors/character/actions.py`
  with `residual_action_scale=None` (no reference to add a residual to in a task).

Both write (B, 28) targets, clipped to the joint limits, into a caller's buffer.
"""
from __future__ import annotations

import numpy as np

from actors.character.actions import ActionMapper
from actors.envs.tasks.motor_module import decode, load_decoder, principal_basis


class JointActions:
    name = "joint"

    def __init__(self):
        self.mapper = ActionMapper("exp_map", None)
        self.action_dim = self.mapper.action_dim

    def targets(self, actions: np.ndarray, proprio: np.ndarray, out: np.ndarray) -> np.ndarray:
        return self.mapper.targets_batch(actions, out)


class LatentActions:
    """z from the policy's [-1, 1] actions: `latent_scale` x action in the full latent space, or,
    with `directions` K > 0, the module's posterior centre plus action_k x latent_scale x std_k
    along its K principal directions (`principal_directions` in its config.json): K numbers to
    explore instead of 60, centred where the experts' z lie rather than at z = 0."""

    name = "latent"

    def __init__(self, module_dir: str, latent_scale: float = 1.0, directions: int = 0):
        self.decoder, size = load_decoder(module_dir)
        self.latent_scale = float(latent_scale)
        self._limits = ActionMapper("exp_map", None)  # only its per-axis joint limits
        self.centre, self.basis = None, None
        if directions > 0:
            self.centre, self.basis = principal_basis(module_dir, directions, size)
            self.basis = self.basis * self.latent_scale  # (K, L): rows already scaled by their std
        self.action_dim = len(self.basis) if self.basis is not None else size

    def latents(self, actions: np.ndarray) -> np.ndarray:
        clipped = np.clip(actions, -1.0, 1.0)
        if self.basis is None:
            return self.latent_scale * clipped
        return self.centre + clipped @ self.basis

    def targets(self, actions: np.ndarray, proprio: np.ndarray, out: np.ndarray) -> np.ndarray:
        out[:] = decode(self.decoder, proprio, self.latents(actions))
        np.minimum(out, self._limits.upper, out=out)
        np.maximum(out, self._limits.lower, out=out)
        return out


def make_action_space(config):
    """The action space a TaskEnvConfig asks for."""
    if config.action == "latent":
        return LatentActions(config.module, config.latent_scale, config.latent_directions)
    return JointActions()
