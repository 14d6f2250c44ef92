"""Clipped PPO on time-major rollout batches (SFV paper §7.3, Supplementary A, Algorithm 1).

One `PPOLearner.update(batch)` call:

1. checks every array of the batch (shape, dtype, finite),
2. evaluates V(obs) and V(next_obs) (the latter only where it is not the next row's obs)
   with the current value network and computes GAE(lambda)
   advantages (policy) and TD(lambda) returns (value targets),
3. keeps only the tuples of ``batch["update_mask"]`` when the batch has one (adaptive tuple
   sampling, paper 002 §5.2, `learner/tuple_sampling.py`: advantages and targets are computed
   on the full trajectories first), normalises the advantages over the (kept) batch and clips
   them to +-adv_clip,
4. runs `update_epochs` passes of shuffled minibatches of the clipped surrogate objective
   plus the value regression (separate networks, separate optimisers), stopping early if
   the approximate KL exceeds `target_kl`,
5. and only then folds the batch's observations into the observation normaliser (all of
   them, masked or not: it estimates the states the policy meets).

The normaliser is updated *after* the epochs so that the learner sees the batch exactly
as the workers' policy did: the first minibatch starts at ratio 1, and approx_kl measures
only what the gradient steps changed.  The new statistics reach the workers with the next
`policy_weights()`.  The one exception is the very first batch, which fits the still-empty
normaliser before the epochs (see `_update`).

If anything fails mid-update (non-finite loss or gradient), the learner is restored to its
state before the call, so a bad batch can be dropped and training can go on.
"""

from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np
import torch

from learner.config import PPOConfig
from learner.errors import BatchFormatError, NonFiniteError, SfvError
from learner.networks import ObservationNormalizer, PolicyNetwork, ValueNetwork, linear_layers
from learner.returns import gae_advantages, td_lambda_returns
from learner.schedule import adapt_rate_to_kl, linear_anneal

STATE_FORMAT_VERSION = 1
FLOAT_ARRAYS = ("obs", "next_obs", "actions", "logp", "rewards")
FLAG_ARRAYS = ("terminated", "truncated")


def clipped_surrogate_loss(
    new_logp: torch.Tensor, old_logp: torch.Tensor, advantages: torch.Tensor, clip_coef: float
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """PPO's pessimistic clipped objective, negated for minimisation.

    Returns (loss, ratio, log_ratio).  Where the ratio has left [1 - eps, 1 + eps] in the
    direction the advantage favours, the clipped term is the max and its gradient is 0.
    """
    log_ratio = new_logp - old_logp
    ratio = log_ratio.exp()
    unclipped = -advantages * ratio
    clipped = -advantages * ratio.clamp(1.0 - clip_coef, 1.0 + clip_coef)
    return torch.maximum(unclipped, clipped).mean(), ratio, log_ratio


def decoupled_surrogate_loss(
    new_logp: torch.Tensor, prox_logp: torch.Tensor, behaviour_logp: torch.Tensor, advantages: torch.Tensor,
    clip_coef: float, max_weight: float,
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """PPO's clipped objective for samples from an older policy (decoupled PPO, Hilton et al.
    2021, "Batch size-invariance for policy optimization"): the ratio is clipped around the
    *proximal* policy (the learner's weights when the update starts) and the behaviour policy
    that drew the samples enters only as an importance weight pi_prox / pi_behaviour,
    truncated at `max_weight` (V-trace's rho-bar, for the variance). Clipping against the
    behaviour policy instead would let an update's first step already sit at the clip edge
    for a lagged sample, so a stale batch would barely train. With no lag both policies are
    one and this is `clipped_surrogate_loss`.

    Returns (loss, ratio, log_ratio) with the ratio against the proximal policy."""
    weight = (prox_logp - behaviour_logp).exp().clamp(max=max_weight)
    log_ratio = new_logp - prox_logp
    ratio = log_ratio.exp()
    unclipped = -advantages * ratio
    clipped = -advantages * ratio.clamp(1.0 - clip_coef, 1.0 + clip_coef)
    return (weight * torch.maximum(unclipped, clipped)).mean(), ratio, log_ratio


def action_bound_loss(action_mean: torch.Tensor, bound: float) -> torch.Tensor:
    """Squared excess of the mean beyond +-bound: the env clips there, so without it the
    reward stops depending on the mean and nothing pulls it back."""
    excess = (action_mean.abs() - bound).clamp(min=0.0)
    return excess.square().sum(-1).mean()


def explained_variance(predicted: np.ndarray, target: np.ndarray) -> float:
    """1 - Var(target - predicted) / Var(target); nan when the target is constant."""
    target_var = float(np.var(target))
    if target_var == 0.0:
        return float("nan")
    return 1.0 - float(np.var(target - predicted)) / target_var


def validate_batch(batch: dict[str, np.ndarray], obs_dim: int, act_dim: int) -> dict[str, np.ndarray]:
    """Contiguous float32/bool views of the batch, or a one-line error naming the bad array."""
    missing = [name for name in FLOAT_ARRAYS + FLAG_ARRAYS if name not in batch]
    if missing:
        raise BatchFormatError(f"rollout batch: missing arrays {missing}")
    rewards_shape = np.shape(batch["rewards"])
    if len(rewards_shape) != 2 or 0 in rewards_shape:
        raise BatchFormatError(f"rollout batch: batch['rewards'] must be a non-empty (T, N) array, got {rewards_shape}")
    expected = {
        "obs": (*rewards_shape, obs_dim),
        "next_obs": (*rewards_shape, obs_dim),
        "actions": (*rewards_shape, act_dim),
        "logp": rewards_shape,
        "rewards": rewards_shape,
        "terminated": rewards_shape,
        "truncated": rewards_shape,
    }
    checked: dict[str, np.ndarray] = {}
    for name, shape in expected.items():
        array = np.asarray(batch[name])
        if array.shape != shape:
            raise BatchFormatError(f"rollout batch: batch[{name!r}] has shape {array.shape}, expected {shape}")
        if name in FLAG_ARRAYS:
            if array.dtype.kind not in "biu":
                raise BatchFormatError(f"rollout batch: batch[{name!r}] must be bool, got {array.dtype}")
            checked[name] = array.astype(bool, copy=False)
            continue
        if array.dtype.kind not in "fiu":
            raise BatchFormatError(f"rollout batch: batch[{name!r}] must be float, got {array.dtype}")
        if not np.isfinite(array).all():
            raise NonFiniteError(f"rollout batch: batch[{name!r}] contains NaN or inf")
        checked[name] = np.ascontiguousarray(array, dtype=np.float32)
    if "update_mask" in batch:
        checked["update_mask"] = _checked_mask(batch["update_mask"], rewards_shape)
    return checked


def _checked_mask(mask, shape: tuple[int, ...]) -> np.ndarray:
    """The optional (T, N) bool mask of the tuples the update trains on (all others only feed
    the advantages of the tuples before them)."""
    mask = np.asarray(mask)
    if mask.shape != shape or mask.dtype != bool:
        raise BatchFormatError(f"rollout batch: batch['update_mask'] must be a bool array of shape {shape}, got {mask.dtype} {mask.shape}")
    if not mask.any():
        raise BatchFormatError("rollout batch: batch['update_mask'] selects no tuple")
    return mask


def _require_finite(value: float | np.ndarray, what: str) -> None:
    if not np.isfinite(value).all():
        raise NonFiniteError(f"PPO update: {what} is NaN or inf")


class PPOLearner:
    """PPO for a fixed-std Gaussian policy with separate policy and value MLPs."""

    def __init__(self, obs_dim: int, act_dim: int, config: PPOConfig | None = None, device: str = "cpu") -> None:
        self.obs_dim = int(obs_dim)
        self.act_dim = int(act_dim)
        self.config = config if config is not None else PPOConfig()
        self.device = torch.device(device)
        cfg = self.config
        # A private generator seeds the init so that building a learner neither reads
        # nor disturbs torch's global RNG.
        self.torch_rng = torch.Generator().manual_seed(cfg.seed)
        self.np_rng = np.random.default_rng(cfg.seed)
        self.policy = PolicyNetwork(obs_dim, act_dim, cfg.policy_hidden, cfg.action_std, self.torch_rng).to(self.device)
        self.value = ValueNetwork(obs_dim, cfg.value_hidden, self.torch_rng, cfg.value_bfloat16).to(self.device)
        self.normalizer = ObservationNormalizer(obs_dim, cfg.obs_clip, cfg.normalizer_max_samples).to(self.device)
        self.policy_optimizer = self._make_optimizer(self.policy, cfg.policy_lr)
        self.policy_lr = float(cfg.policy_lr)  # the rate in force: annealed, or adapted to the KL
        self.value_optimizer = self._make_optimizer(self.value, cfg.value_lr)
        self._policy_lag = 0  # of the batch being learned from (`update`)

    def _make_optimizer(self, network: torch.nn.Module, lr: float) -> torch.optim.Optimizer:
        # torch picks the multi-tensor paths by default only on CUDA. On CPU, foreach makes SGD's
        # and Adam's step ~5x faster than per-parameter loops, and fused Adam (one kernel)
        # another 3x: 0.8 ms instead of 2.5 ms per step of the 1024-512 net, measured.
        if self.config.optimizer == "sgd":
            return torch.optim.SGD(network.parameters(), lr=lr, momentum=self.config.sgd_momentum, foreach=True)
        return torch.optim.Adam(network.parameters(), lr=lr, eps=1e-5, fused=True)

    # ------------------------------------------------------------------ schedule

    def set_progress(self, samples: int) -> dict[str, float]:
        """Policy learning rate and exploration std for the next batch, `samples` collected so far.

        Call it between updates only: the update's log-probabilities must use the std the
        batch was sampled with.  Returns the values set (for the metrics).
        """
        cfg = self.config
        if cfg.desired_kl is None:
            self.policy_lr = linear_anneal(cfg.policy_lr, cfg.policy_lr_final, samples, cfg.anneal_samples)
        lr = self.policy_lr
        std = linear_anneal(cfg.action_std, cfg.action_std_final, samples, cfg.anneal_samples)
        self._set_policy_lr(lr)
        with torch.no_grad():
            self.policy.log_std.fill_(math.log(std))
        return {"charts/policy_lr": lr, "charts/action_std": std}

    def _set_policy_lr(self, lr: float) -> None:
        for group in self.policy_optimizer.param_groups:
            group["lr"] = lr

    # ------------------------------------------------------------------ update

    def update(self, batch: dict[str, np.ndarray]) -> dict[str, float]:
        """One PPO iteration on a time-major batch; returns CleanRL-named metrics.

        Raises NonFiniteError (learner unchanged) for NaN/inf input, losses or gradients.
        `batch["policy_lag"]` (optional, default 0): how many updates older than this learner the
        oldest weights that drew the batch are; above 0 the loss is `decoupled_surrogate_loss`.
        """
        arrays = validate_batch(batch, self.obs_dim, self.act_dim)
        self._policy_lag = int(batch.get("policy_lag", 0))
        # A full backup (weights, Adam moments, normaliser, RNG: ~20 MB, some ms at the paper's
        # sizes) is what lets a failure in minibatch k undo the k - 1 steps already taken.
        before = copy.deepcopy(self.state_dict())
        try:
            return self._update(arrays)
        except BaseException:
            self.load_state_dict(before)
            raise

    def _to_tensor(self, array: np.ndarray) -> torch.Tensor:
        return torch.from_numpy(array).to(self.device)

    def _next_values(self, obs: np.ndarray, next_obs: np.ndarray, next_flat: torch.Tensor, values: np.ndarray) -> np.ndarray:
        """V(next_obs), (steps, envs). Within an episode next_obs[t] is obs[t + 1], whose value
        is already known; only rows where that does not hold (episode ends, the batch's last
        step) go through the value network: ~5 % of the rows instead of all of them."""
        steps, envs = values.shape
        known = np.zeros((steps, envs), dtype=bool)
        known[:-1] = (next_obs[:-1] == obs[1:]).all(axis=-1)
        next_values = np.empty_like(values)
        next_values[:-1][known[:-1]] = values[1:][known[:-1]]
        rest = ~known.ravel()
        if rest.any():
            rows = torch.from_numpy(np.flatnonzero(rest)).to(self.device)
            next_values.reshape(-1)[rest] = self.value(self.normalizer(next_flat[rows])).double().cpu().numpy()
        return next_values

    def _update(self, arrays: dict[str, np.ndarray]) -> dict[str, float]:
        cfg = self.config
        steps, envs = arrays["rewards"].shape
        obs = self._to_tensor(arrays["obs"].reshape(steps * envs, self.obs_dim))
        next_obs = self._to_tensor(arrays["next_obs"].reshape(steps * envs, self.obs_dim))
        # An empty normaliser is fitted before the first update, so that update already
        # trains in the normalised input space every later batch uses.  The freshly
        # initialised policy outputs means ~0 for any input scaling, so the ratios barely move.
        fit_normalizer_first = float(self.normalizer.count) == 0
        if fit_normalizer_first:
            self.normalizer.update(obs)
        with torch.no_grad():
            obs_norm = self.normalizer(obs)
            values = self.value(obs_norm).double().cpu().numpy().reshape(steps, envs)
            next_values = self._next_values(arrays["obs"], arrays["next_obs"], next_obs, values)
        _require_finite(values, "value estimates V(obs)")
        _require_finite(next_values, "value estimates V(next_obs)")

        flags = (arrays["terminated"], arrays["truncated"])
        advantages = gae_advantages(arrays["rewards"], values, next_values, *flags, cfg.gamma, cfg.gae_lambda).ravel()
        value_targets = td_lambda_returns(arrays["rewards"], next_values, *flags, cfg.gamma, cfg.td_lambda).ravel()
        _require_finite(advantages, "GAE advantages")
        _require_finite(value_targets, "TD(lambda) value targets")
        if cfg.reward_max is not None:  # DeepMimic's val_min / val_max: a return lies in [0, r_max / (1 - gamma)]
            np.clip(value_targets, 0.0, cfg.reward_max / max(1.0 - cfg.gamma, 1e-8), out=value_targets)
        kept = None if "update_mask" not in arrays else np.flatnonzero(arrays["update_mask"].ravel())
        if kept is not None:  # the selected tuples only, their advantages from the full trajectories
            advantages, value_targets = advantages[kept], value_targets[kept]
        if cfg.norm_adv and advantages.size > 1:
            advantages = (advantages - advantages.mean()) / (advantages.std() + 1e-8)
            advantages = np.clip(advantages, -cfg.adv_clip, cfg.adv_clip)

        actions = self._to_tensor(arrays["actions"].reshape(steps * envs, self.act_dim))
        columns = (obs_norm, actions, self._to_tensor(arrays["logp"].ravel()))
        if self._policy_lag > 0:  # the proximal policy's log-probs: the learner's weights before the update
            with torch.no_grad():
                columns += (self.policy.distribution(obs_norm).log_prob(actions).sum(-1),)
        if kept is not None:
            rows = torch.from_numpy(kept).to(self.device)
            columns = tuple(column[rows] for column in columns)
        obs_col, actions_col, logp_col, *prox_col = columns
        minibatches = self._minibatches(
            obs_col, actions_col, logp_col,
            self._to_tensor(advantages.astype(np.float32)),
            self._to_tensor(value_targets.astype(np.float32)),
            *prox_col,
        )
        sums: dict[str, float] = {}
        gradient_steps = 0
        for minibatch in minibatches:
            stats = self._gradient_step(*minibatch)
            gradient_steps += 1
            for key, value in stats.items():
                sums[key] = sums.get(key, 0.0) + value
            if cfg.desired_kl is not None:
                self.policy_lr = adapt_rate_to_kl(self.policy_lr, stats["approx_kl"], cfg.desired_kl)
                self._set_policy_lr(self.policy_lr)
            if cfg.target_kl is not None and stats["approx_kl"] > cfg.target_kl:
                break

        if not fit_normalizer_first:
            self.normalizer.update(obs)
        metrics = {f"losses/{key}": total / gradient_steps for key, total in sums.items()}
        metrics["losses/explained_variance"] = explained_variance(values.ravel() if kept is None else values.ravel()[kept], value_targets)
        metrics["charts/gradient_steps"] = float(gradient_steps)
        metrics["charts/policy_lr"] = self.policy_lr
        metrics["charts/normalizer_samples"] = float(self.normalizer.count)
        return metrics

    def _minibatches(self, *columns: torch.Tensor):
        """`update_epochs` passes over the batch, each in a fresh random order, as tuples of
        the columns' rows; minibatches split the batch into near-equal parts."""
        num_samples = columns[0].shape[0]
        num_minibatches = max(1, round(num_samples / self.config.minibatch_size))
        for _ in range(self.config.update_epochs):
            order = self.np_rng.permutation(num_samples)
            for index in np.array_split(order, num_minibatches):
                rows = torch.from_numpy(index).to(self.device)
                yield tuple(column[rows] for column in columns)

    def _gradient_step(
        self,
        obs_norm: torch.Tensor,
        actions: torch.Tensor,
        old_logp: torch.Tensor,
        advantages: torch.Tensor,
        value_targets: torch.Tensor,
        prox_logp: torch.Tensor | None = None,
    ) -> dict[str, float]:
        cfg = self.config
        dist = self.policy.distribution(obs_norm)
        new_logp = dist.log_prob(actions).sum(-1)
        if prox_logp is None:
            surrogate, ratio, log_ratio = clipped_surrogate_loss(new_logp, old_logp, advantages, cfg.clip_coef)
        else:
            surrogate, ratio, log_ratio = decoupled_surrogate_loss(new_logp, prox_logp, old_logp, advantages, cfg.clip_coef,
                                                                   cfg.max_importance_weight)
        bound_loss = action_bound_loss(dist.mean, cfg.action_bound)
        policy_loss = surrogate + cfg.action_bound_coef * bound_loss
        value_loss = 0.5 * (self.value(obs_norm) - value_targets).square().mean()
        _require_finite(policy_loss.item(), "policy loss")
        _require_finite(value_loss.item(), "value loss")

        self.policy_optimizer.zero_grad(set_to_none=True)
        self.value_optimizer.zero_grad(set_to_none=True)
        # The two networks share no parameters, so one backward pass serves both optimisers.
        (policy_loss + value_loss).backward()
        max_norm = cfg.max_grad_norm if cfg.max_grad_norm is not None else math.inf
        policy_grad_norm = torch.nn.utils.clip_grad_norm_(self.policy.parameters(), max_norm)
        value_grad_norm = torch.nn.utils.clip_grad_norm_(self.value.parameters(), max_norm)
        _require_finite(policy_grad_norm.item(), "gradients of the policy network")
        _require_finite(value_grad_norm.item(), "gradients of the value network")
        self.policy_optimizer.step()
        self.value_optimizer.step()

        with torch.no_grad():
            return {
                "policy_loss": surrogate.item(),
                "value_loss": value_loss.item(),
                "action_bound_loss": bound_loss.item(),
                "entropy": dist.entropy().sum(-1).mean().item(),
                "approx_kl": ((ratio - 1.0) - log_ratio).mean().item(),
                "clipfrac": ((ratio - 1.0).abs() > cfg.clip_coef).float().mean().item(),
            }

    # ------------------------------------------------------------------ export

    def policy_weights(self) -> dict[str, np.ndarray]:
        """Flat dict of float32 arrays for `learner.policy.NumpyPolicy` and the ONNX export.

        Keys: obs_mean, obs_std (obs_dim,), obs_clip (), action_std (act_dim,), and per
        Linear layer i: ``layer{i}.weight`` as (in_dim, out_dim) and ``layer{i}.bias``.
        """
        with torch.no_grad():
            weights = {
                "obs_mean": self.normalizer.mean.float().cpu().numpy(),
                "obs_std": self.normalizer.std().cpu().numpy(),
                "obs_clip": np.array(self.normalizer.clip, dtype=np.float32),
                "action_std": self.policy.log_std.exp().float().cpu().numpy(),
            }
            for index, layer in enumerate(linear_layers(self.policy)):
                weights[f"layer{index}.weight"] = layer.weight.T.contiguous().float().cpu().numpy()
                weights[f"layer{index}.bias"] = layer.bias.float().cpu().numpy()
        return weights

    # ------------------------------------------------------------------ state

    def state_dict(self) -> dict[str, Any]:
        """Everything needed for an exact resume (tensors and plain python values only)."""
        return {
            "format_version": STATE_FORMAT_VERSION,
            "obs_dim": self.obs_dim,
            "act_dim": self.act_dim,
            "config": self.config.to_dict(),
            "policy": self.policy.state_dict(),
            "value": self.value.state_dict(),
            "normalizer": self.normalizer.state_dict(),
            "policy_optimizer": self.policy_optimizer.state_dict(),
            "value_optimizer": self.value_optimizer.state_dict(),
            "numpy_rng": self.np_rng.bit_generator.state,
            "torch_rng": self.torch_rng.get_state(),
            "policy_lr": self.policy_lr,
        }

    def start_from(self, state: dict[str, Any]) -> int:
        """Another learner's weights (a `state_dict()`): policy, value network and normaliser, not its
        optimisers, RNGs or rates. A policy with more action numbers than this one (a residual root
        wrench's six after the joints') gives its first `act_dim`; returns how many were dropped."""
        obs_dim, act_dim = state.get("obs_dim"), state.get("act_dim")
        if obs_dim != self.obs_dim or act_dim is None or act_dim < self.act_dim:
            raise SfvError(f"start from: a learner for obs_dim/act_dim {(obs_dim, act_dim)} cannot start this one "
                           f"{(self.obs_dim, self.act_dim)} (the observation must match; actions may only be dropped)")
        policy = dict(state["policy"])
        dropped = int(act_dim - self.act_dim)
        if dropped:
            layers = sorted({int(k.split(".")[1]) for k in policy if k.startswith("mean_net.")})
            for name in (f"mean_net.{layers[-1]}.weight", f"mean_net.{layers[-1]}.bias", "log_std"):
                policy[name] = policy[name][: self.act_dim]
        try:
            self.policy.load_state_dict(policy)
            self.value.load_state_dict(state["value"])
            self.normalizer.load_state_dict(state["normalizer"])
        except (KeyError, RuntimeError) as exc:
            reason = " ".join(str(exc).split())[:300]
            raise SfvError(f"start from: the networks do not fit this learner ({type(exc).__name__}: {reason})") from exc
        return dropped

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Restore a `state_dict()`; hyper-parameters (learning rates) stay those of `self.config`."""
        dims = (state.get("obs_dim"), state.get("act_dim"))
        if dims != (self.obs_dim, self.act_dim):
            raise SfvError(
                f"learner state: saved for obs_dim/act_dim {dims}, this learner has {(self.obs_dim, self.act_dim)}"
            )
        try:
            self._load_state(state)
        except (KeyError, RuntimeError, ValueError, TypeError) as exc:
            reason = " ".join(str(exc).split())
            raise SfvError(f"learner state: does not fit this learner ({type(exc).__name__}: {reason})") from exc

    def _load_state(self, state: dict[str, Any]) -> None:
        self.policy.load_state_dict(state["policy"])
        self.value.load_state_dict(state["value"])
        self.normalizer.load_state_dict(state["normalizer"])
        self.policy_optimizer.load_state_dict(state["policy_optimizer"])
        self.value_optimizer.load_state_dict(state["value_optimizer"])
        # An adapted rate is state, not a hyper-parameter: a resume continues from it.
        adapted = self.config.desired_kl is not None and "policy_lr" in state
        self.policy_lr = float(state["policy_lr"]) if adapted else float(self.config.policy_lr)
        for optimizer, lr in ((self.policy_optimizer, self.policy_lr), (self.value_optimizer, self.config.value_lr)):
            for group in optimizer.param_groups:
                group["lr"] = lr
        rng_state = state["numpy_rng"]
        self.np_rng = np.random.default_rng()
        self.np_rng.bit_generator.state = rng_state
        self.torch_rng.set_state(state["torch_rng"])
