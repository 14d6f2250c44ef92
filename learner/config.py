"""PPO hyper-parameters (SFV paper, Supplementary A, with the deviations documented below).

Deviations from the paper, all chosen to learn faster per sample; every one is a field,
so the paper's setting is one flag away:

* ``optimizer="adam"`` instead of SGD+momentum (policy 2.5e-6, value 0.01).  Adam's
  per-parameter step size makes the update insensitive to the scale of the rewards and of
  the 1024-unit layers' gradients, so one learning rate works from the first batch; with
  the paper's SGD steps the policy barely moves per batch (approx KL ~1e-6 per update in
  our probe below) and needs ~150 M samples.  The policy step stays small because the
  action std is fixed and small: shifting the mean by d in one dimension costs
  d**2 / (2 * std**2) nats of KL.  Probe (synthetic 197-D obs / 36-D actions, batch 4096,
  4 epochs, 1024-512 nets): Adam 2e-5 gives approx_kl ~0.012 and clipfrac ~0.2 per update
  (a single epoch moves it about half as far: median approx_kl 0.0098 vs 0.017 on the walk); 5e-5 gives ~0.04 and ~0.43 (most of the step clipped away); 1e-5 gives ~0.007 and ~0.1.
  ``target_kl`` only guards against runaway updates.  Not yet tuned on the real env.
* ``update_epochs=1`` and ``policy_lr=5e-5``: one pass of 16 minibatches of 256 over each
  4096-sample batch, as in DeepMimic's own PPO agent (``"Epochs": 1`` in its humanoid
  config; the paper does not say), with the step that makes one pass move the policy as far
  as four passes at 2e-5 did.  Measured on ``deepmimic:walk`` (1 worker x 32 envs, RSI, one
  seed, training normalised return averaged over the 8 iterations before each mark):
  4 epochs at 2e-5: 0.0061 / 0.0073 at 200 k / 400 k samples, median approx_kl 0.017;
  1 epoch at 2e-5: 0.0062 / 0.0086, approx_kl 0.010; 1 epoch at 5e-5: 0.0064 / 0.0112,
  approx_kl 0.019, episodes 42 steps long instead of 34.  One pass also takes a quarter of
  the update time, which on a 2-core machine was most of each iteration.
* ``action_std=0.1``: 5 % of the env's normalised [-1, 1] action range (DeepMimic's
  humanoid uses a fixed exploration noise of 0.05 in its own normalised action units).

Advantages are normalised over the whole batch (4096 samples give a steadier mean/std
than a 256-sample minibatch) and then clipped to ``±adv_clip``, as DeepMimic does.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

from learner.errors import ConfigError
from learner.tuple_sampling import TUPLE_SAMPLING_MODES


@dataclass
class PPOConfig:
    batch_size: int = field(default=4096, metadata={"help": "samples collected per PPO iteration (paper: 4096)"})
    minibatch_size: int = field(default=256, metadata={"help": "samples per gradient step (paper: 256)"})
    update_epochs: int = field(
        default=1,
        metadata={"help": "passes over each batch (DeepMimic: 1); more re-use per simulated sample, bounded by target_kl"},
    )
    gamma: float = field(default=0.95, metadata={"help": "discount factor (paper: 0.95)"})
    gae_lambda: float = field(default=0.95, metadata={"help": "GAE(lambda) for policy advantages (paper: 0.95)"})
    td_lambda: float = field(default=0.95, metadata={"help": "TD(lambda) for value targets (paper: 0.95)"})
    clip_coef: float = field(default=0.2, metadata={"help": "PPO ratio clipping threshold epsilon (paper: 0.2)"})
    max_importance_weight: float = field(
        default=2.0, metadata={"help": "truncation of pi_learner / pi_behaviour for samples drawn by older weights (asynchronous runs)"})
    target_kl: float | None = field(
        default=0.05,
        metadata={"help": "stop the update's remaining minibatches once approx KL exceeds this; None disables"},
    )
    norm_adv: bool = field(default=True, metadata={"help": "normalise advantages to zero mean, unit std over the whole batch"})
    adv_clip: float = field(default=4.0, metadata={"help": "clip normalised advantages to +-adv_clip (DeepMimic: 4)"})
    policy_hidden: tuple[int, ...] = field(
        default=(1024, 512), metadata={"help": "policy MLP hidden layer sizes, ReLU activations (paper: 1024, 512)"}
    )
    value_hidden: tuple[int, ...] = field(
        default=(1024, 512), metadata={"help": "value MLP hidden layer sizes, ReLU activations (paper: 1024, 512)"}
    )
    action_std: float = field(
        default=0.1,
        metadata={"help": "fixed std of the diagonal Gaussian policy, in the env's normalised [-1, 1] action units"},
    )
    action_bound: float = field(
        default=1.0, metadata={"help": "the env clips actions to +-action_bound; the policy mean is penalised beyond it"}
    )
    action_bound_coef: float = field(
        default=10.0,
        metadata={"help": "weight of the squared penalty on policy means outside +-action_bound (0 disables)"},
    )
    optimizer: str = field(default="adam", metadata={"choices": ("adam", "sgd"), "help": "'adam' (default, faster) or 'sgd' (paper: SGD, momentum 0.9)"})
    policy_lr: float = field(default=5e-5, metadata={"help": "policy learning rate at the start (paper SGD: 2.5e-6)"})
    desired_kl: float | None = field(
        default=None,
        metadata={"help": "adapt the policy learning rate after each minibatch to keep approx KL near this (rsl_rl: 0.01); "
                          "None: policy_lr with its anneal (measured: docs/training.md)"},
    )
    policy_lr_final: float | None = field(
        default=None,
        metadata={"help": "policy learning rate reached after anneal_samples, linearly from policy_lr (None: constant)"},
    )
    action_std_final: float | None = field(
        default=None,
        metadata={"help": "exploration std reached after anneal_samples, linearly from action_std (None: constant)"},
    )
    anneal_samples: int = field(
        default=16_000_000,
        metadata={"help": "samples over which policy_lr and action_std move to their final values, then held (independent of the budget)"},
    )
    value_lr: float = field(default=1e-3, metadata={"help": "value learning rate (paper SGD: 0.01)"})
    value_bfloat16: bool = field(default=False, metadata={"help": "the value network's matrix products in bfloat16 (autocast; the policy stays "
                                 "float32): a faster update where the hardware has bfloat16 (AVX512-BF16 or AMX CPUs, GPUs), slower where it "
                                 "is emulated (measured: docs/scaling.md)"})
    sgd_momentum: float = field(default=0.9, metadata={"help": "momentum when optimizer='sgd' (paper: 0.9)"})
    max_grad_norm: float | None = field(
        default=1.0, metadata={"help": "clip each network's gradient to this global L2 norm; None disables"}
    )
    reward_max: float | None = field(
        default=1.0,
        metadata={"help": "rewards lie in [0, reward_max]: value targets are clipped to [0, reward_max / (1 - gamma)] (DeepMimic); sfv train sets it to the env reward's maximum; None disables"},
    )
    obs_clip: float = field(default=10.0, metadata={"help": "clip normalised observations to +-obs_clip"})
    normalizer_max_samples: int = field(
        default=1_000_000,
        metadata={"help": "stop updating the observation normaliser after this many samples (DeepMimic: 1e6)"},
    )
    seed: int = field(default=0, metadata={"help": "seed of the learner's network init and minibatch shuffling"})
    tuple_sampling: str = field(
        default="all",
        metadata={"choices": TUPLE_SAMPLING_MODES, "help": "tuples each update trains on: 'all' collected, or 'adaptive' (paper 002 §5.2, eq. 13: per episode tuples_per_episode consecutive ones, the start drawn with P(t) ~ 1/(n_t + 1) over frames; learner/tuple_sampling.py)"},
    )
    tuples_per_episode: int = field(default=32, metadata={"help": "consecutive tuples each episode segment contributes under adaptive tuple sampling (paper 002: 32)"})

    def __post_init__(self) -> None:
        self.policy_hidden = tuple(int(h) for h in self.policy_hidden)
        self.value_hidden = tuple(int(h) for h in self.value_hidden)
        self.validate()

    def validate(self) -> None:
        """Raise ConfigError naming every bad field (also after fields were changed in place)."""
        problems = []
        if self.optimizer not in ("adam", "sgd"):
            problems.append(f"optimizer must be 'adam' or 'sgd', got {self.optimizer!r}")
        if self.tuple_sampling not in TUPLE_SAMPLING_MODES:
            problems.append(f"tuple_sampling must be one of {', '.join(TUPLE_SAMPLING_MODES)}, got {self.tuple_sampling!r}")
        if self.desired_kl is not None and self.policy_lr_final is not None:
            problems.append("desired_kl adapts the learning rate; it cannot also be annealed (policy_lr_final)")
        for name in ("policy_lr_final", "action_std_final", "desired_kl"):
            if getattr(self, name) is not None and not getattr(self, name) > 0.0:
                problems.append(f"{name} must be > 0 (or None)")
        for name in ("batch_size", "minibatch_size", "update_epochs", "tuples_per_episode", "anneal_samples"):
            if getattr(self, name) < 1:
                problems.append(f"{name} must be >= 1")
        for name in ("gamma", "gae_lambda", "td_lambda"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                problems.append(f"{name} must be in [0, 1]")
        for name in ("clip_coef", "action_std", "obs_clip", "policy_lr", "value_lr", "adv_clip", "action_bound", "max_importance_weight"):
            if not getattr(self, name) > 0.0:
                problems.append(f"{name} must be > 0")
        if self.reward_max is not None and not self.reward_max > 0.0:
            problems.append("reward_max must be > 0 (or None)")
        if any(h < 1 for h in self.policy_hidden + self.value_hidden):
            problems.append("hidden layer sizes must be >= 1")
        if problems:
            raise ConfigError("PPOConfig: " + "; ".join(problems))

    def to_dict(self) -> dict[str, Any]:
        """Plain python types only, so it fits a weights_only checkpoint and a JSON log."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> "PPOConfig":
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(values) - known)
        if unknown:
            raise ConfigError(f"PPOConfig: unknown fields {unknown}")
        return cls(**values)
