"""The Gaussian policy evaluated inside rollout workers, in pure numpy float32.

It consumes the flat weight dict of `learner.ppo.PPOLearner.policy_weights()`:

* ``obs_mean``, ``obs_std`` (obs_dim,) and ``obs_clip`` (): normalisation baked by the learner,
* ``layer{i}.weight`` (in_dim, out_dim) and ``layer{i}.bias`` (out_dim,): the mean MLP,
  ReLU after every layer but the last,
* ``action_std`` (act_dim,): the fixed diagonal std.

Workers step many envs at once, so `act` takes a batch and writes into buffers allocated
once for `max_batch` rows; with `out_actions`/`out_logp` it can write straight into the
worker's trajectory arrays and allocates nothing per call.  No torch here: workers stay
light and a Ray object-store round trip of the weights is a handful of numpy arrays.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from learner.errors import SfvError

HALF_LOG_TWO_PI = 0.5 * math.log(2.0 * math.pi)


def policy_layers(weights: Mapping[str, np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]]:
    """The (weight (in, out), bias (out,)) pairs in order, after checking that they chain."""
    required = ("obs_mean", "obs_std", "obs_clip", "action_std", "layer0.weight", "layer0.bias")
    missing = [key for key in required if key not in weights]
    if missing:
        raise SfvError(f"policy weights: missing arrays {missing}")
    layers = []
    width = np.shape(weights["obs_mean"])[0] if np.ndim(weights["obs_mean"]) == 1 else -1
    if width < 1 or np.shape(weights["obs_std"]) != (width,):
        raise SfvError("policy weights: obs_mean and obs_std must be equal (obs_dim,) vectors")
    index = 0
    while f"layer{index}.weight" in weights:
        weight = np.asarray(weights[f"layer{index}.weight"])
        bias = np.asarray(weights.get(f"layer{index}.bias"))
        if weight.ndim != 2 or weight.shape[0] != width or bias.shape != (weight.shape[1],):
            raise SfvError(
                f"policy weights: layer{index} has weight {weight.shape} and bias {bias.shape}, "
                f"expected ({width}, out) and (out,)"
            )
        layers.append((weight, bias))
        width = weight.shape[1]
        index += 1
    if np.shape(weights["action_std"]) != (width,):
        raise SfvError(f"policy weights: action_std has shape {np.shape(weights['action_std'])}, expected ({width},)")
    for key in ("obs_std", "action_std", "obs_clip"):
        if not np.all(np.asarray(weights[key]) > 0):
            raise SfvError(f"policy weights: {key} must be positive")
    for key, array in weights.items():
        if not np.all(np.isfinite(array)):
            raise SfvError(f"policy weights: {key} contains NaN or inf")
    return layers


def gaussian_log_normaliser(std: np.ndarray) -> np.float32:
    """sum(log std) + k/2 log(2 pi): the part of -log N(a | mu, diag(std^2)) without a."""
    return np.float32(np.log(np.asarray(std, dtype=np.float64)).sum() + np.shape(std)[0] * HALF_LOG_TWO_PI)


def diagonal_gaussian_logp(
    actions: np.ndarray,
    mean: np.ndarray,
    std: np.ndarray,
    log_normaliser: np.float32,
    scratch: np.ndarray,
    out: np.ndarray,
) -> np.ndarray:
    """log N(actions | mean, diag(std^2)) summed over the last axis, written into `out`.

    `scratch` is an (M, act_dim) work buffer.  It works from the stored float32 actions
    (not the noise) so the learner's recomputed log-probability matches to rounding.
    """
    np.subtract(actions, mean, out=scratch)
    np.divide(scratch, std, out=scratch)
    np.square(scratch, out=scratch)
    np.sum(scratch, axis=1, out=out)
    out *= np.float32(-0.5)
    out -= log_normaliser
    return out


class NumpyPolicy:
    """Batched N(mu(obs), diag(action_std^2)) with mu a ReLU MLP; float32 throughout."""

    def __init__(self, weights: Mapping[str, np.ndarray], max_batch: int = 64) -> None:
        self._max_batch = 0
        self._shapes: list[tuple[tuple[int, ...], tuple[int, ...]]] | None = None
        self.load_weights(weights)
        self._allocate(max(1, int(max_batch)))

    @property
    def obs_dim(self) -> int:
        return self._obs_mean.shape[0]

    @property
    def act_dim(self) -> int:
        return self._action_std.shape[0]

    def load_weights(self, weights: Mapping[str, np.ndarray]) -> None:
        """Replace the weights; copies in place when the architecture is unchanged.

        Layers are kept transposed, (out, in), and activations feature-major, (width, M):
        W^T @ h^T is ~25 % faster in OpenBLAS than h @ W for the few rows of a worker's
        batch (measured at M = 32 on the 1024-512 net).
        """
        layers = policy_layers(weights)
        shapes = [(weight.shape, bias.shape) for weight, bias in layers]
        if self._shapes == shapes:  # same architecture (layer0's shape fixes obs_dim)
            for (weight_t, bias), (new_weight, new_bias) in zip(self._layers, layers):
                np.copyto(weight_t, np.asarray(new_weight).T, casting="same_kind")
                np.copyto(bias[:, 0], new_bias, casting="same_kind")
            np.copyto(self._obs_mean[:, 0], weights["obs_mean"], casting="same_kind")
            np.copyto(self._obs_std[:, 0], weights["obs_std"], casting="same_kind")
            np.copyto(self._action_std, weights["action_std"], casting="same_kind")
        else:
            self._shapes = shapes
            self._layers = [(np.ascontiguousarray(np.asarray(w, dtype=np.float32).T), np.array(b, dtype=np.float32)[:, None])
                            for w, b in layers]
            self._obs_mean = np.array(weights["obs_mean"], dtype=np.float32)[:, None]
            self._obs_std = np.array(weights["obs_std"], dtype=np.float32)[:, None]
            self._action_std = np.array(weights["action_std"], dtype=np.float32)
            if self._max_batch:
                self._allocate(self._max_batch)
        self._obs_clip = np.float32(weights["obs_clip"])
        self._neg_obs_clip = -self._obs_clip
        self._log_normaliser = gaussian_log_normaliser(self._action_std)

    def _allocate(self, rows: int) -> None:
        self._max_batch = rows
        self._input = np.empty((self.obs_dim, rows), dtype=np.float32)
        self._activations = [np.empty((weight_t.shape[0], rows), dtype=np.float32) for weight_t, _ in self._layers]
        self._noise = np.empty((rows, self.act_dim), dtype=np.float32)

    def mean(self, obs: np.ndarray) -> np.ndarray:
        """Action means for a (M, obs_dim) batch; a view into an internal buffer that the
        next call overwrites."""
        obs = np.asarray(obs)
        if obs.ndim != 2 or obs.shape[1] != self.obs_dim:
            raise ValueError(f"NumpyPolicy: obs must be (M, {self.obs_dim}), got {obs.shape}")
        rows = obs.shape[0]
        if rows > self._max_batch:
            self._allocate(rows)
        hidden = self._input[:, :rows]
        np.subtract(obs.T, self._obs_mean, out=hidden)
        np.divide(hidden, self._obs_std, out=hidden)
        np.clip(hidden, self._neg_obs_clip, self._obs_clip, out=hidden)
        last = len(self._layers) - 1
        for index, ((weight_t, bias), buffer) in enumerate(zip(self._layers, self._activations)):
            output = buffer[:, :rows]
            np.matmul(weight_t, hidden, out=output)
            np.add(output, bias, out=output)
            if index != last:
                np.maximum(output, 0.0, out=output)
            hidden = output
        return hidden.T

    def act(
        self,
        obs: np.ndarray,
        rng: np.random.Generator | None = None,
        deterministic: bool = False,
        out_actions: np.ndarray | None = None,
        out_logp: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Sample (or take the mean of) the policy for a (M, obs_dim) batch.

        Returns actions (M, act_dim) float32, unclipped (the env clips), and their log
        density logp (M,) float32.  Pass `out_actions`/`out_logp` (e.g. rows of the
        worker's trajectory buffers) to write there instead of allocating.
        """
        mean = self.mean(obs)
        rows = mean.shape[0]
        actions = np.empty((rows, self.act_dim), np.float32) if out_actions is None else out_actions
        logp = np.empty(rows, np.float32) if out_logp is None else out_logp
        noise = self._noise[:rows]
        if deterministic:
            np.copyto(actions, mean)
        else:
            if rng is None:
                raise ValueError("NumpyPolicy.act: a np.random.Generator is required unless deterministic=True")
            rng.standard_normal(dtype=np.float32, out=noise)
            np.multiply(noise, self._action_std, out=actions)
            np.add(actions, mean, out=actions)
        diagonal_gaussian_logp(actions, mean, self._action_std, self._log_normaliser, noise, logp)
        return actions, logp
