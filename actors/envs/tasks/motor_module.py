"""The one seam to the frozen motor module's decoder (NPMP 004 §3.3-3.4).

Contract with the motor-module code (issue 16 item 3, `learner/motor_decoder.py`):
`LatentDecoder.load(MODULE_DIR)` then `decoder(proprio (B, 196) float32, z (B, L)) ->
(B, 28)` absolute PD targets in radians. Proprioception is the first 196 entries of
`FeatureExtractor`'s observation (height, link positions, rotations, linear and angular
velocities in the heading frame: no phase, no reference), which is what the task env computes
for every env in one batched pass. Anything that depends on how the decoder is stored stays
in this file.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from learner.errors import SfvError

_LATENT_KEYS = ("latent_size", "latent_dim", "z_dim")


def load_decoder(module_dir: str | Path):
    """(decoder, latent size) of a motor module directory (or `pretrained`, the shipped one);
    one-line SfvError when it is not one."""
    from learner.motor_decoder import module_path

    path = module_path(module_dir)
    if not (path / "config.json").is_file():
        raise SfvError(f"{path}: not a motor module (no config.json; `sfv distill` writes one)")
    try:
        from learner.motor_decoder import LatentDecoder
    except ImportError as exc:
        raise SfvError(f"{path}: the motor-module decoder (learner/motor_decoder.py) is not installed ({exc})") from None
    decoder = LatentDecoder.load(path)
    return decoder, latent_size(decoder, path)


def latent_size(decoder, module_dir: Path) -> int:
    for key in _LATENT_KEYS:
        value = getattr(decoder, key, None)
        if value is not None:
            return int(value)
    config = json.loads((Path(module_dir) / "config.json").read_text())
    for section in (config, config.get("module", {}), config.get("model", {})):
        for key in _LATENT_KEYS:
            if isinstance(section, dict) and key in section:
                return int(section[key])
    raise SfvError(f"{module_dir}/config.json: no latent size ({' / '.join(_LATENT_KEYS)})")


def decode(decoder, proprio: np.ndarray, z: np.ndarray) -> np.ndarray:
    """(B, 28) float64 PD targets for a batch."""
    return np.asarray(decoder(np.ascontiguousarray(proprio, np.float32), np.ascontiguousarray(z, np.float32)), np.float64)


def principal_basis(module_dir: str | Path, directions: int, latent_dim: int) -> tuple[np.ndarray, np.ndarray]:
    """(centre (L,), rows (K, L) = the K principal directions times their std) of the encoder's
    posterior means, from the module's config.json (`latent_range.principal`, written by `sfv distill`);
    K is `directions` or the number recorded, whichever is smaller."""
    from learner.motor_decoder import module_path

    path = module_path(module_dir) / "config.json"
    principal = json.loads(path.read_text()).get("latent_range", {}).get("principal")
    if not principal:
        raise SfvError(f"{path}: no principal latent directions (a module distilled before they were recorded); "
                       "use --env.latent-directions 0")
    directions = min(directions, len(principal["directions"]))  # a small latent has fewer (min(16, latent size))
    centre = np.asarray(principal["mean"], np.float64)
    rows = np.asarray(principal["directions"][:directions], np.float64) * np.asarray(principal["std"][:directions])[:, None]
    if centre.shape != (latent_dim,) or rows.shape[1] != latent_dim:
        raise SfvError(f"{path}: principal directions of size {centre.shape[0]}, the decoder's latent is {latent_dim}")
    return centre, rows
