"""The NPMP motor module in torch: encoder, AR(1) prior, decoder, ELBO (004 §3.3 eq. 4; Merel et al. 2019).

- Encoder q(z_t | z_{t-1}, s_{t+1..t+k}) = N(mu, diag(std^2)), mu and log std an ELU MLP of the
  normalised future features (`actors/envs/tasks/future_reference.py`) and z_{t-1} (Merel et al.'s form).
- Prior p(z_t | z_{t-1}) = N(alpha z_{t-1}, (1 - alpha^2) sigma^2 I): AR(1), stationary with
  marginal N(0, sigma^2 I), which is also the prior of the first step of a sequence.
- Decoder pi(a_t | s_t, z_t) = N(mu(s_t, z_t), diag(std^2)): an ELU MLP of the normalised
  proprioception (`actors/envs/tasks/proprioception.py`, no reference) and z_t; mu is the absolute PD
  targets (rad) the env writes into ctrl; the std is state-independent, learned or fixed
  (`learn_action_std`).
- Loss per step = -log pi(a*_t | s_t, z_t) + beta KL(q || p), a*_t the targets of the expert's
  mean action, z_t ~ q by reparameterisation; KL analytic between diagonal Gaussians; averaged
  over the B x W steps of B windows of W consecutive steps, z carried through the window (BPTT).

Deviations: the first step of each training window starts from z_{t-1} = 0 with the stationary
prior (windows are cut from longer episodes; one-shot imitation starts its episodes the same
way). The likelihood is of the expert's mean action (004 fits the executed noisy action; the
mean is the less noisy target of the same correction, the issue's contract).
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import torch
from torch import nn

from learner.errors import ConfigError
from learner.motor_config import SIZE_FIELDS, MotorModuleConfig

HALF_LOG_TWO_PI = 0.5 * math.log(2.0 * math.pi)
OUTPUT_GAIN = 0.01  # small last layers: the decoder starts at the mean targets, the encoder at N(0, 1)
LOG_STD_RANGE = (-7.0, 2.0)


def elu_mlp(in_dim: int, hidden: Sequence[int], out_dim: int, generator: torch.Generator | None = None) -> nn.Sequential:
    sizes = [in_dim, *hidden, out_dim]
    layers: list[nn.Module] = []
    for index, (fan_in, fan_out) in enumerate(zip(sizes[:-1], sizes[1:])):
        linear = nn.Linear(fan_in, fan_out)
        last = index == len(sizes) - 2
        nn.init.orthogonal_(linear.weight, gain=OUTPUT_GAIN if last else math.sqrt(2.0), generator=generator)
        nn.init.zeros_(linear.bias)
        layers.append(linear)
        if not last:
            layers.append(nn.ELU())
    return nn.Sequential(*layers)


def gaussian_kl(mu_q: torch.Tensor, std_q: torch.Tensor, mu_p: torch.Tensor, std_p: torch.Tensor) -> torch.Tensor:
    """KL(N(mu_q, std_q^2) || N(mu_p, std_p^2)) per component (diagonal Gaussians, analytic)."""
    ratio = (std_q / std_p) ** 2
    return 0.5 * (ratio + ((mu_q - mu_p) / std_p) ** 2 - 1.0 - torch.log(ratio))


def prior_params(z_prev: torch.Tensor | None, alpha: float, sigma: float, like: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Mean and std of p(z_t | z_{t-1}); the stationary N(0, sigma^2) when z_prev is None."""
    if z_prev is None:
        return torch.zeros_like(like), torch.full_like(like, sigma)
    return alpha * z_prev, torch.full_like(like, math.sqrt(1.0 - alpha * alpha) * sigma)


def prior_sample(z_prev: torch.Tensor, alpha: float, sigma: float, noise: torch.Tensor) -> torch.Tensor:
    """z_t = alpha z_{t-1} + sqrt(1 - alpha^2) sigma eps (how a free-running prior moves)."""
    return alpha * z_prev + math.sqrt(1.0 - alpha * alpha) * sigma * noise


class MotorModule(nn.Module):
    def __init__(self, config: MotorModuleConfig, generator: torch.Generator | None = None):
        super().__init__()
        unsized = [name for name in SIZE_FIELDS if getattr(config, name) is None]
        if unsized:
            raise ConfigError(f"MotorModule: {', '.join(unsized)} not set (a dataset's sizes: MotorModuleConfig.with_sizes_of)")
        self.config = c = config
        self.encoder = elu_mlp(c.future_dim + c.latent_dim, c.encoder_hidden, 2 * c.latent_dim, generator)
        self.decoder = elu_mlp(c.proprio_dim + c.latent_dim, c.decoder_hidden, c.action_dim, generator)
        self.action_log_std = nn.Parameter(torch.full((c.action_dim,), math.log(c.init_action_std)),
                                           requires_grad=c.learn_action_std)
        for name, dim in (("proprio", c.proprio_dim), ("future", c.future_dim), ("target", c.action_dim)):
            self.register_buffer(f"{name}_mean", torch.zeros(dim))
            self.register_buffer(f"{name}_std", torch.ones(dim))

    def set_normalisation(self, proprio: np.ndarray, future: np.ndarray, targets: np.ndarray, floor: float = 1e-3) -> None:
        """Means and stds of the inputs and targets from (a sample of) the training rows."""
        for name, values in (("proprio", proprio), ("future", future), ("target", targets)):
            values = np.asarray(values, dtype=np.float64)
            getattr(self, f"{name}_mean").copy_(torch.as_tensor(values.mean(axis=0)))
            getattr(self, f"{name}_std").copy_(torch.as_tensor(np.maximum(values.std(axis=0), floor)))

    def _normalise(self, x: torch.Tensor, name: str) -> torch.Tensor:
        clip = self.config.input_clip
        return ((x - getattr(self, f"{name}_mean")) / getattr(self, f"{name}_std")).clamp(-clip, clip)

    def encode(self, future: torch.Tensor, z_prev: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Mean and std of q(z_t | z_{t-1}, future)."""
        out = self.encoder(torch.cat((self._normalise(future, "future"), z_prev), dim=-1))
        mu, log_std = out.chunk(2, dim=-1)
        return mu, log_std.clamp(*LOG_STD_RANGE).exp()

    def decode_normalised(self, proprio: torch.Tensor, z: torch.Tensor) -> torch.Tensor:
        return self.decoder(torch.cat((self._normalise(proprio, "proprio"), z), dim=-1))

    def decode(self, proprio: torch.Tensor, z: torch.Tensor) -> torch.Tensor:
        """The decoder's mean: absolute PD targets (rad)."""
        return self.target_mean + self.target_std * self.decode_normalised(proprio, z)

    def normalised_action_std(self) -> torch.Tensor:
        return self.action_log_std.exp().clamp_min(self.config.min_action_std)

    def action_std(self) -> torch.Tensor:
        """The decoder's std in rad."""
        return self.target_std * self.normalised_action_std()

    def sequence_loss(self, proprio: torch.Tensor, future: torch.Tensor, targets: torch.Tensor,
                      generator: torch.Generator | None = None, sample: bool = True) -> dict[str, torch.Tensor]:
        """ELBO terms over (B, W, .) windows: loss, nll, kl (per step means), rmse (rad) of the decoder mean.

        `sample=False` uses the encoder's mean for z (validation)."""
        c = self.config
        batch, window = future.shape[:2]
        z_prev = future.new_zeros(batch, c.latent_dim)
        latents, kls = [], []
        for t in range(window):
            mu, std = self.encode(future[:, t], z_prev)
            z = mu + std * torch.randn(mu.shape, generator=generator, device=mu.device, dtype=mu.dtype) if sample else mu
            prior_mu, prior_std = prior_params(None if t == 0 else z_prev, c.alpha, c.prior_std, mu)
            kls.append(gaussian_kl(mu, std, prior_mu, prior_std).sum(-1))
            latents.append(z)
            z_prev = z
        z_all = torch.stack(latents, dim=1)
        predicted = self.decode_normalised(proprio, z_all)
        goal = (targets - self.target_mean) / self.target_std
        std = self.normalised_action_std()
        nll = (0.5 * ((goal - predicted) / std) ** 2 + torch.log(std) + HALF_LOG_TWO_PI).sum(-1)
        kl = torch.stack(kls, dim=1)
        rmse = (((predicted - goal) * self.target_std) ** 2).mean().sqrt()
        return {"loss": (nll + c.beta * kl).mean(), "nll": nll.mean(), "kl": kl.mean(), "rmse": rmse}

    def decoder_weights(self) -> dict[str, np.ndarray]:
        """The decoder for `learner/motor_decoder.py`: layers as (in, out), the target scaling baked
        into the last layer so it outputs radians."""
        linears = [m for m in self.decoder if isinstance(m, nn.Linear)]
        weights = {"proprio_mean": self.proprio_mean, "proprio_std": self.proprio_std,
                   "input_clip": torch.tensor(self.config.input_clip), "action_std": self.action_std(),
                   "latent_dim": torch.tensor(self.config.latent_dim)}
        for index, linear in enumerate(linears):
            weight, bias = linear.weight.T, linear.bias
            if index == len(linears) - 1:
                weight, bias = weight * self.target_std, bias * self.target_std + self.target_mean
            weights[f"layer{index}.weight"], weights[f"layer{index}.bias"] = weight, bias
        return {key: value.detach().cpu().numpy().astype(np.float32 if key != "latent_dim" else np.int64)
                for key, value in weights.items()}
