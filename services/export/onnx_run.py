"""A run's newest checkpoint as an ONNX policy, checked against the numpy policy it came from."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from learner.errors import SfvError

CHECK_ROWS = 64
CHECK_TOLERANCE = 1e-4  # float32 MLP: ONNX and numpy differ by rounding only (~1e-6)


def export_run_onnx(run_dir: str | Path, out: str | Path, seed: int = 0, checkpoint: str = "best") -> dict:
    """Write the deterministic policy (observation normalisation baked in) to `out`, with what a
    robot runtime needs as its metadata (`runtime_metadata.py`: joints, gains, actions, rates,
    observation layout).

    The written file is reloaded with onnxruntime and compared with `NumpyPolicy` on random
    observations spread like the training data (the run's own normaliser statistics, some
    beyond the clip); a mismatch removes the file and raises.
    """
    from learner.onnx_export import OnnxPolicy, export_policy_onnx
    from learner.policy import NumpyPolicy
    from services.training.run_dir import load_run

    out = Path(out)
    if out.suffix.lower() != ".onnx":
        raise SfvError(f"{out}: the policy file must end in .onnx")
    from services.export.runtime_metadata import runtime_metadata
    from services.training.policy_source import PolicySource

    config, weights = load_run(run_dir, checkpoint)
    env = PolicySource(None, config.env, config.motion, "").make_env()  # the run's body and reference, as trained
    export_policy_onnx(weights, out, runtime_metadata(env))
    rng = np.random.default_rng(seed)
    mean, std = np.asarray(weights["obs_mean"]), np.asarray(weights["obs_std"])
    obs = (mean + 3.0 * std * rng.standard_normal((CHECK_ROWS, mean.shape[0]))).astype(np.float32)
    expected = NumpyPolicy(weights, max_batch=CHECK_ROWS).mean(obs)
    actual = OnnxPolicy(out, num_threads=1).mean(obs)
    difference = float(np.max(np.abs(actual - expected)))
    if not difference <= CHECK_TOLERANCE:
        out.unlink(missing_ok=True)
        raise SfvError(f"{out}: exported policy disagrees with the checkpoint by {difference:.3g} (removed)")
    return {"onnx": str(out), "obs_dim": int(mean.shape[0]), "act_dim": int(expected.shape[1]),
            "max_abs_diff_vs_checkpoint": difference, "bytes": out.stat().st_size}
