"""The motor module's decoder at rollout time: numpy float32, no torch (004 §3.3; contract of issue 16).

    decoder = LatentDecoder.load("MODULE")            # or MODULE/decoder.npz
    targets = decoder(proprio (B, 196), z (B, latent_dim))   # (B, 28) absolute PD targets, rad

Inputs: s_t of `actors/envs/tasks/proprioception.py` (no reference, no phase) and a latent z (from the
encoder in one-shot imitation, from a task policy when the module is reused). Output: the mean
of pi(a_t | s_t, z_t), the 28 actuator targets the env writes into ctrl, NOT residual actions
and not clipped (clip to the joint limits, `ActionMapper.lower/upper`, as the env does).

decoder.npz holds `proprio_mean`, `proprio_std` (196,), `input_clip` (), `latent_dim` (),
`action_std` (28,) (the decoder's Gaussian std, rad) and `layer{i}.weight` (in, out),
`layer{i}.bias` (out,) of an ELU MLP over [clip((s - mean) / std), z], the last layer linear and
already scaled to radians. A module directory holds config.json, module.pt (the torch
checkpoint), decoder.onnx (`learner/motor_decoder_onnx.py`) and decoder.npz.
"""
from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from learner.atomic_io import atomic_output
from learner.errors import SfvError

DECODER_NPZ = "decoder.npz"
# The motor module that ships in the repository (`--module pretrained`): its decoder, ONNX twin,
# config.json and PROVENANCE.md (the commands, budgets and figures that made it).
PRETRAINED = "pretrained"
PRETRAINED_DIR = Path(__file__).resolve().parent / "pretrained" / "motor_module"
REQUIRED = ("proprio_mean", "proprio_std", "input_clip", "latent_dim", "action_std", "layer0.weight", "layer0.bias")


def elu(x: np.ndarray) -> np.ndarray:
    return np.where(x > 0, x, np.expm1(np.minimum(x, 0)))


def decoder_layers(weights: Mapping[str, np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]]:
    """The (weight (in, out), bias) pairs after checking they chain from 196 + latent to the action std's width."""
    missing = [key for key in REQUIRED if key not in weights]
    if missing:
        raise SfvError(f"motor decoder weights: missing arrays {missing}")
    width = int(np.shape(weights["proprio_mean"])[0]) + int(weights["latent_dim"])
    layers, index = [], 0
    while f"layer{index}.weight" in weights:
        weight, bias = np.asarray(weights[f"layer{index}.weight"]), np.asarray(weights[f"layer{index}.bias"])
        if weight.ndim != 2 or weight.shape[0] != width or bias.shape != (weight.shape[1],):
            raise SfvError(f"motor decoder weights: layer{index} is {weight.shape} / {bias.shape}, expected ({width}, out) / (out,)")
        layers.append((weight.astype(np.float32), bias.astype(np.float32)))
        width = weight.shape[1]
        index += 1
    if np.shape(weights["action_std"]) != (width,):
        raise SfvError(f"motor decoder weights: action_std is {np.shape(weights['action_std'])}, expected ({width},)")
    if not all(np.all(np.isfinite(np.asarray(v, dtype=np.float64))) for v in weights.values()):
        raise SfvError("motor decoder weights: NaN or inf")
    return layers


def save_decoder_npz(weights: Mapping[str, np.ndarray], path: str | os.PathLike) -> Path:
    decoder_layers(weights)
    with atomic_output(path, suffix=".npz") as tmp:
        np.savez(tmp, **{key: np.asarray(value) for key, value in weights.items()})
    return Path(path)


def module_path(module: str | os.PathLike) -> Path:
    """A module directory by name: `pretrained` is the shipped module (PRETRAINED_DIR), anything else a path."""
    if str(module) == PRETRAINED:
        if not (PRETRAINED_DIR / DECODER_NPZ).is_file():
            raise SfvError(f"--module pretrained: the shipped module is missing from {PRETRAINED_DIR} (a partial checkout?)")
        return PRETRAINED_DIR
    return Path(module)


class LatentDecoder:
    """pi(a | s, z)'s mean in numpy float32, batched."""

    def __init__(self, weights: Mapping[str, np.ndarray]):
        self.layers = decoder_layers(weights)
        self.proprio_mean = np.asarray(weights["proprio_mean"], np.float32)
        self.proprio_std = np.asarray(weights["proprio_std"], np.float32)
        self.input_clip = np.float32(weights["input_clip"])
        self.latent_dim = int(weights["latent_dim"])
        self.action_std = np.asarray(weights["action_std"], np.float32)
        self.proprio_dim = self.proprio_mean.shape[0]
        self.action_dim = self.action_std.shape[0]

    @classmethod
    def load(cls, path: str | os.PathLike) -> "LatentDecoder":
        """From a module directory (its decoder.npz), an npz file, or `pretrained`."""
        path = module_path(path)
        if path.is_dir():
            path = path / DECODER_NPZ
        if not path.is_file():
            raise SfvError(f"{path}: motor decoder not found")
        try:
            with np.load(path, allow_pickle=False) as npz:
                weights = {key: npz[key] for key in npz.files}
        except (OSError, ValueError, EOFError) as exc:
            raise SfvError(f"{path}: unreadable motor decoder ({type(exc).__name__}: {exc})") from None
        try:
            return cls(weights)
        except SfvError as exc:
            raise SfvError(f"{path}: {exc}") from None

    def __call__(self, proprio: np.ndarray, z: np.ndarray) -> np.ndarray:
        proprio, z = np.asarray(proprio, np.float32), np.asarray(z, np.float32)
        if proprio.ndim != 2 or proprio.shape[1] != self.proprio_dim or z.shape != (proprio.shape[0], self.latent_dim):
            raise ValueError(f"LatentDecoder: proprio (B, {self.proprio_dim}) and z (B, {self.latent_dim}), got {proprio.shape} and {z.shape}")
        scaled = np.clip((proprio - self.proprio_mean) / self.proprio_std, -self.input_clip, self.input_clip)
        hidden = np.concatenate((scaled, z), axis=1)
        last = len(self.layers) - 1
        for index, (weight, bias) in enumerate(self.layers):
            hidden = hidden @ weight + bias
            if index != last:
                hidden = elu(hidden)
        return hidden
