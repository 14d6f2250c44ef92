"""Settings of the NPMP motor module (004 §3.3, Merel et al. 2019 "Neural probabilistic motor primitives").

The text of 004 stored here names the ELBO (its eq. 4) and k = 5 but no latent size, alpha or
beta; the latent size and alpha are Merel et al. 2019's (NPMP: a 60-D latent, an AR(1) prior with
alpha = 0.95), taken from that paper as recalled, not from a stored text. Beta is measured here
(0.3, not their 0.1: the lever table `bench/scripts/npmp_levers.py`).
Sizes, learning rate and window are this machine's choices (2 CPU cores), said in their help.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

from learner.errors import ConfigError


SIZE_FIELDS = ("proprio_dim", "future_dim", "action_dim")


@dataclass
class MotorModuleConfig:
    latent_dim: int = field(default=60, metadata={"help": "size of the latent motor intention z (Merel et al. 2019: 60)"})
    alpha: float = field(default=0.95, metadata={"help": "AR(1) prior p(z_t|z_t-1) = N(alpha z_t-1, (1 - alpha^2) sigma^2) (Merel et al. 2019: 0.95)"})
    prior_std: float = field(default=1.0, metadata={"help": "sigma: the prior's stationary std of each latent component"})
    beta: float = field(default=0.3, metadata={"help": "weight of KL(q || p) against the action log-likelihood (004 eq. 4; Merel et al. 2019: "
                                                "0.1; 0.3 keeps the prior's samples on their feet: the lever table in docs/motor.md)"})
    encoder_hidden: tuple[int, ...] = field(default=(512, 512), metadata={"help": "encoder MLP hidden sizes, ELU (Merel et al.: wider; sized for 2 CPU cores)"})
    decoder_hidden: tuple[int, ...] = field(default=(512, 512), metadata={"help": "decoder MLP hidden sizes, ELU (smooth in z, which a task policy explores)"})
    init_action_std: float = field(default=0.5, metadata={"help": "initial std of the decoder's Gaussian, in units of each target's dataset std (learned, state-independent)"})
    min_action_std: float = field(default=0.01, metadata={"help": "floor of the decoder's std in the same units (keeps the log-likelihood bounded)"})
    learn_action_std: bool = field(default=True, metadata={"help": "learn the decoder's std; off: it stays at init_action_std. The "
                                                            "reconstruction term scales as 1/std^2, so a learned std that shrinks to the floor "
                                                            "makes beta's KL weight 2,500x weaker than at std .5 (MoCapAct fixes it, at .1 of the "
                                                            "action range, with beta .1)"})
    input_clip: float = field(default=10.0, metadata={"help": "clip normalised encoder and decoder inputs to +-this"})
    lr: float = field(default=3e-4, metadata={"help": "Adam learning rate"})
    window: int = field(default=10, metadata={"help": "consecutive steps per training sequence (BPTT through z_t-1 -> z_t)"})
    batch_windows: int = field(default=64, metadata={"help": "sequences per gradient step (steps per step: batch_windows x window)"})
    max_grad_norm: float = field(default=1.0, metadata={"help": "clip the gradient's global L2 norm to this"})
    validation_fraction: float = field(default=0.05, metadata={"help": "fraction of the episodes kept out of training for the validation loss"})
    seed: int = field(default=0, metadata={"help": "seed of the network init, window sampling and latent noise"})
    # The sizes below are the dataset's (its character's proprioception and actuators): `with_sizes_of`
    # sets them from its arrays; None until then.
    proprio_dim: int | None = field(default=None, metadata={"help": "decoder input s_t (actors/envs/tasks/proprioception.py); from the dataset"})
    future_dim: int | None = field(default=None, metadata={"help": "encoder input s_t+1..t+k (actors/envs/tasks/future_reference.py); from the dataset"})
    action_dim: int | None = field(default=None, metadata={"help": "decoder output: absolute PD targets (rad), one per actuator; from the dataset"})

    def __post_init__(self) -> None:
        self.encoder_hidden = tuple(int(h) for h in self.encoder_hidden)
        self.decoder_hidden = tuple(int(h) for h in self.decoder_hidden)
        problems = []
        if not 0.0 <= self.alpha < 1.0:
            problems.append(f"alpha must be in [0, 1), got {self.alpha}")
        for name in ("prior_std", "lr", "init_action_std", "min_action_std", "input_clip", "max_grad_norm"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                problems.append(f"{name} must be > 0, got {value}")
        if not (math.isfinite(self.beta) and self.beta >= 0):
            problems.append(f"beta must be >= 0, got {self.beta}")
        if not 0.0 <= self.validation_fraction < 1.0:
            problems.append(f"validation_fraction must be in [0, 1), got {self.validation_fraction}")
        for name in ("latent_dim", "window", "batch_windows"):
            if getattr(self, name) < 1:
                problems.append(f"{name} must be >= 1")
        for name in SIZE_FIELDS:
            if getattr(self, name) is not None and getattr(self, name) < 1:
                problems.append(f"{name} must be >= 1")
        if any(h < 1 for h in self.encoder_hidden + self.decoder_hidden):
            problems.append("hidden sizes must be >= 1")
        if problems:
            raise ConfigError("MotorModuleConfig: " + "; ".join(problems))

    def with_sizes_of(self, proprio: int, future: int, actions: int) -> "MotorModuleConfig":
        """This config with the dataset's input and output sizes."""
        return dataclasses.replace(self, proprio_dim=proprio, future_dim=future, action_dim=actions)

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> "MotorModuleConfig":
        unknown = sorted(set(values) - {f.name for f in dataclasses.fields(cls)})
        if unknown:
            raise ConfigError(f"MotorModuleConfig: unknown fields {unknown}")
        return cls(**values)
