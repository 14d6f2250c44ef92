"""Policy and value MLPs (paper §9) and the running observation normaliser.

Both networks take *normalised* observations; `ObservationNormalizer` turns raw env
observations into those.  The policy is a Gaussian with a state-dependent mean and a
fixed diagonal std kept in a buffer, so it is saved and exported but never trained.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import torch
from torch import nn
from torch.distributions import Normal

# Orthogonal init gains as in CleanRL's PPO: sqrt(2) for ReLU layers, a tiny policy
# output so the initial mean is ~0 (the neutral action), unit gain for the value head.
HIDDEN_GAIN = math.sqrt(2.0)
POLICY_OUTPUT_GAIN = 0.01
VALUE_OUTPUT_GAIN = 1.0


def mlp(
    in_dim: int,
    hidden_sizes: Sequence[int],
    out_dim: int,
    output_gain: float,
    generator: torch.Generator | None = None,
) -> nn.Sequential:
    """Linear/ReLU stack with orthogonal weights and zero biases; the last layer is linear."""
    sizes = [in_dim, *hidden_sizes, out_dim]
    layers: list[nn.Module] = []
    for index, (fan_in, fan_out) in enumerate(zip(sizes[:-1], sizes[1:])):
        linear = nn.Linear(fan_in, fan_out)
        is_output = index == len(sizes) - 2
        nn.init.orthogonal_(linear.weight, gain=output_gain if is_output else HIDDEN_GAIN, generator=generator)
        nn.init.zeros_(linear.bias)
        layers.append(linear)
        if not is_output:
            layers.append(nn.ReLU())
    return nn.Sequential(*layers)


def linear_layers(network: nn.Module) -> list[nn.Linear]:
    """The network's Linear layers in forward order (what the numpy/ONNX exports consume)."""
    return [module for module in network.modules() if isinstance(module, nn.Linear)]


class PolicyNetwork(nn.Module):
    """pi(a|s) = N(mu(s), diag(action_std**2)), mu an MLP of the normalised observation."""

    def __init__(
        self,
        obs_dim: int,
        act_dim: int,
        hidden_sizes: Sequence[int],
        action_std: float,
        generator: torch.Generator | None = None,
    ) -> None:
        super().__init__()
        self.mean_net = mlp(obs_dim, hidden_sizes, act_dim, POLICY_OUTPUT_GAIN, generator)
        self.register_buffer("log_std", torch.full((act_dim,), math.log(action_std)))

    def forward(self, obs_norm: torch.Tensor) -> torch.Tensor:
        """Action mean, shape (batch, act_dim)."""
        return self.mean_net(obs_norm)

    def distribution(self, obs_norm: torch.Tensor) -> Normal:
        mean = self(obs_norm)
        return Normal(mean, self.log_std.exp().expand_as(mean))

    def log_prob(self, obs_norm: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """Log density of `actions` (summed over action dims), shape (batch,)."""
        return self.distribution(obs_norm).log_prob(actions).sum(-1)


class ValueNetwork(nn.Module):
    """V(s): an MLP of the normalised observation with a scalar output.

    `bfloat16`: its matrix products run in bfloat16 (autocast; weights, gradients and Adam stay
    float32, the output is returned as float32). Only the value network may: PPO's ratios need the
    policy's means to a precision bfloat16 does not keep (its 8 mantissa bits put a mean about
    0.4 % off, 0.04 of the 0.1 exploration std, and 36 such dimensions move a log-ratio by about
    0.24, beyond the 0.2 clip), while a value regressed onto noisy returns loses nothing
    measurable (`learner/config.py`: `value_bfloat16`)."""

    def __init__(
        self,
        obs_dim: int,
        hidden_sizes: Sequence[int],
        generator: torch.Generator | None = None,
        bfloat16: bool = False,
    ) -> None:
        super().__init__()
        self.value_net = mlp(obs_dim, hidden_sizes, 1, VALUE_OUTPUT_GAIN, generator)
        self.bfloat16 = bool(bfloat16)

    def forward(self, obs_norm: torch.Tensor) -> torch.Tensor:
        """State values, shape (batch,)."""
        if not self.bfloat16:
            return self.value_net(obs_norm).squeeze(-1)
        with torch.autocast(obs_norm.device.type, dtype=torch.bfloat16):
            out = self.value_net(obs_norm)
        return out.float().squeeze(-1)


class ObservationNormalizer(nn.Module):
    """Running per-feature mean/variance of observations; maps obs to clip((obs - mean) / std).

    Statistics accumulate in float64 with the parallel (Chan et al.) combination of batch
    moments, so the order and size of batches does not matter.  After `max_samples`
    observations the statistics freeze, which keeps the policy's input distribution
    stationary for the rest of training (DeepMimic does the same).
    """

    def __init__(self, obs_dim: int, clip: float, max_samples: int, eps: float = 1e-8) -> None:
        super().__init__()
        self.clip = float(clip)
        self.max_samples = int(max_samples)
        self.eps = float(eps)
        self.register_buffer("mean", torch.zeros(obs_dim, dtype=torch.float64))
        self.register_buffer("var", torch.ones(obs_dim, dtype=torch.float64))
        self.register_buffer("count", torch.zeros((), dtype=torch.float64))

    @property
    def frozen(self) -> bool:
        return float(self.count) >= self.max_samples

    @torch.no_grad()
    def update(self, obs: torch.Tensor) -> None:
        """Fold a (batch, obs_dim) block of raw observations into the running statistics."""
        remaining = self.max_samples - int(self.count)
        if remaining <= 0:
            return
        batch = obs.reshape(-1, self.mean.numel())[:remaining].to(torch.float64)
        batch_count = batch.shape[0]
        if batch_count == 0:
            return
        batch_mean = batch.mean(0)
        batch_var = batch.var(0, correction=0)
        total = self.count + batch_count
        delta = batch_mean - self.mean
        sum_sq = self.var * self.count + batch_var * batch_count + delta.square() * self.count * batch_count / total
        self.mean += delta * batch_count / total
        self.var.copy_(sum_sq / total)
        self.count.copy_(total)

    def std(self) -> torch.Tensor:
        """float32 std actually used for normalising (and exported to the actors)."""
        return torch.sqrt(self.var + self.eps).float()

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        normalised = (obs - self.mean.float()) / self.std()
        return normalised.clamp(-self.clip, self.clip)
