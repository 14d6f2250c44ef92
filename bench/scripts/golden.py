"""Golden rollout and PPO update: digests that a behaviour-preserving change must keep.

`python bench/scripts/golden.py --out FILE.json` trains two tiny serial runs (RSI without a server,
ASI through the embedded gRPC server), 2 PPO iterations each, and writes the SHA-256 of the
rollout arrays of one worker's first `sample` call and of the final policy weights, plus a
few summary numbers. `--check FILE.json` recomputes them and exits 1 naming what changed.
A restructuring is bit-identical when the digests match on the same platform (the `platform`
entry: CPU, Python and library versions); `bench/results/golden_digests.json` holds the
reference, and tests/bench/test_golden_digests.py checks it in CI. Rewrite it only on purpose,
with the reason in the commit message. The digests follow the default (synchronous) training
path.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # run from a checkout without installing

PLATFORM_KEY = "platform"


def _digest(arrays: dict) -> str:
    h = hashlib.sha256()
    for key in sorted(arrays):
        value = np.ascontiguousarray(arrays[key])
        h.update(key.encode())
        h.update(str(value.dtype).encode())
        h.update(value.tobytes())
    return h.hexdigest()


def _config(out: str, init: str):
    from services.training.config import TrainConfig

    config = TrainConfig(motion="deepmimic:walk", out=out, workers=2, envs_per_worker=4, init=init, samples=2 * 1024,
                         runner="in_process", torch_threads=1, eval_every=0, plot_every=0, checkpoint_every=1)
    config.ppo.batch_size = 1024
    config.ppo.minibatch_size = 256
    return config


def _rollout_digest() -> dict:
    """One worker's first sample() with a freshly initialised learner's weights."""
    import torch

    from actors.motion.formats.io import load_motion
    from actors.rollout.worker import RolloutWorker, WorkerSpec
    from learner.ppo import PPOLearner

    torch.set_num_threads(1)
    config = _config("unused", "rsi")
    motion = load_motion(config.motion)
    worker = RolloutWorker(WorkerSpec(motion, config.env, 4, "rsi", 0, config.ppo.gamma))
    learner = PPOLearner(worker.env.obs_dim, worker.action_dim, config.ppo)
    batch = worker.sample(learner.policy_weights(), 0, 64)
    keys = ("obs", "next_obs", "actions", "logp", "rewards", "terminated", "truncated")
    return {"rollout_sha256": _digest({k: batch[k] for k in keys}), "rollout_reward_sum": float(np.sum(batch["rewards"], dtype=np.float64))}


def _training_digest(init: str) -> dict:
    from learner.checkpoint import latest_checkpoint, load_checkpoint
    from services.training.driver import Trainer

    with tempfile.TemporaryDirectory() as tmp:
        out = str(Path(tmp) / f"golden_{init}")
        Trainer(_config(out, init), progress=False).run()
        payload = load_checkpoint(latest_checkpoint(out))
        weights = {k: v.numpy() if hasattr(v, "numpy") else np.asarray(v) for k, v in payload["policy_weights"].items()}
        rows = [json.loads(line) for line in Path(out, "metrics.jsonl").read_text().splitlines()]
    return {f"{init}_weights_sha256": _digest(weights), f"{init}_last_return": rows[-1].get("charts/episode_return_mean"),
            f"{init}_samples": rows[-1].get("samples")}


def compute() -> dict:
    result = _rollout_digest()
    for init in ("rsi", "asi"):
        result.update(_training_digest(init))
    return result


def platform() -> dict:
    """What the bits depend on besides the code: the CPU and the numeric libraries."""
    import platform as host

    import mujoco
    import torch

    cpu = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")), host.processor()) if Path("/proc/cpuinfo").is_file() else host.processor()
    return {"cpu": cpu, "machine": host.machine(), "python": host.python_version(), "numpy": np.__version__,
            "torch": torch.__version__, "mujoco": mujoco.__version__}


def changed_digests(expected: dict, result: dict) -> list[str]:
    """The recorded entries (the platform aside) that the recomputed result does not match."""
    return [k for k in expected if k != PLATFORM_KEY and expected[k] != result.get(k)]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--out", help="write the digests to this JSON file")
    group.add_argument("--check", help="compare with the digests in this JSON file")
    args = parser.parse_args(argv)
    result = compute()
    if args.out:
        result[PLATFORM_KEY] = platform()
        Path(args.out).write_text(json.dumps(result, indent=1) + "\n")
        print(json.dumps(result, indent=1))
        return 0
    expected = json.loads(Path(args.check).read_text())
    changed = changed_digests(expected, result)
    for key in changed:
        print(f"{key}: expected {expected[key]}, got {result.get(key)}")
    print("bit-identical" if not changed else f"{len(changed)} digests changed")
    return 1 if changed else 0


if __name__ == "__main__":
    sys.exit(main())
