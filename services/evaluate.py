"""Evaluate a trained policy: normalised return as SFV defines it, episode length, fall rate.

The normalised return of an episode is its return over the maximum possible return of that
episode (reward 1 at every control step up to the horizon), so it lies in [0, 1]; early
termination forfeits the rest. The policy acts deterministically (its mean). The policy can
come from a run directory (newest checkpoint) or from an exported ONNX file alone.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from actors.errors import SfvError
from actors.imitation_env import ImitationEnv
from actors.motion_io import load_motion
from services.run_dir import CONFIG_FILE
from services.train_config import TrainConfig


def load_run(run_dir: str | Path) -> tuple[TrainConfig, dict]:
    """The run's config and the newest checkpoint's policy weights (numpy)."""
    from learner.checkpoint import load_checkpoint
    from services.run_dir import checkpoint_files

    run_dir = Path(run_dir)
    config_path = run_dir / CONFIG_FILE
    if not config_path.is_file():
        raise SfvError(f"{run_dir}: not a run directory (no {CONFIG_FILE})")
    config = TrainConfig.from_dict(json.loads(config_path.read_text()))
    checkpoints = checkpoint_files(run_dir)
    if not checkpoints:
        raise SfvError(f"{run_dir}: no checkpoint yet")
    # The newest, verified: a corrupt or tampered one is an error, never silently an older policy.
    payload = load_checkpoint(checkpoints[-1])
    if not isinstance(payload.get("policy_weights"), dict):
        raise SfvError(f"{checkpoints[-1]}: checkpoint holds no policy weights")
    weights = {k: v.numpy() if hasattr(v, "numpy") else np.asarray(v) for k, v in payload["policy_weights"].items()}
    return config, weights


def evaluate_policy(policy, env: ImitationEnv, episodes: int, seed: int = 0, init: str = "rsi") -> dict:
    """Run `episodes` deterministic episodes; `policy.act(obs[None], deterministic=True)`."""
    returns, lengths, falls = [], [], []
    obs_row = np.zeros((1, env.observation_space.shape[0]), np.float32)
    for episode in range(episodes):
        obs, _ = env.reset(seed=seed + episode, options={"init": init})
        obs_row[0] = obs
        total, steps, fell = 0.0, 0, False
        while True:
            action, _ = policy.act(obs_row, deterministic=True)
            obs, reward, terminated, truncated, _ = env.step(action[0])
            obs_row[0] = obs
            total += reward
            steps += 1
            if terminated or truncated:
                fell = bool(terminated)
                break
        returns.append(total / (env.max_reward * env.max_episode_steps))
        lengths.append(steps)
        falls.append(fell)
    return {
        "normalized_return": float(np.mean(returns)),
        "normalized_return_std": float(np.std(returns)),
        "episode_length": float(np.mean(lengths)),
        "episode_seconds": float(np.mean(lengths)) / env.config.control_hz,
        "fall_rate": float(np.mean(falls)),
        "episodes": episodes,
    }


def make_policy(run_dir: str | Path | None, onnx: str | Path | None, weights: dict | None):
    if onnx is not None:
        from learner.onnx_export import OnnxPolicy

        return OnnxPolicy(onnx)
    from actors.policy import NumpyPolicy

    return NumpyPolicy(weights, max_batch=1)


def evaluate_run(run_dir: str | Path, episodes: int = 10, seed: int = 0, init: str = "rsi", onnx: str | None = None, motion: str | None = None) -> dict:
    if onnx is not None and run_dir is None:
        if motion is None:
            raise SfvError(f"{onnx}: evaluating an ONNX policy alone needs --motion")
        from services.train_config import TrainConfig

        config, weights = TrainConfig(motion=motion), None
    elif onnx is not None:
        # The run only supplies the env settings: read config.json, not the (torch) checkpoint.
        from services.export.policy_source import read_run_config

        config, weights = read_run_config(run_dir), None
    else:
        config, weights = load_run(run_dir)
    from threadpoolctl import threadpool_limits

    threadpool_limits(1, user_api="blas")  # batch-1 inference: BLAS threads only spin
    env = ImitationEnv(load_motion(motion or config.motion), config.env)
    policy = make_policy(run_dir, onnx, weights)
    result = evaluate_policy(policy, env, episodes, seed, init)
    result.update(motion=env.motion.name, init=init)
    return result
