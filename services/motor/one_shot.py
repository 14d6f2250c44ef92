"""One-shot imitation with the motor module (004 §3.3 and Supplementary C, Fig. A.1).

"One-shot imitation involves providing the trained NPMP with a state-sequence and asking it to
generate a sequence of actions that would reproduce that movement." Closed loop, per control
step: the encoder sees the clip's next 5 reference states relative to the *simulated*
character (`actors/envs/tasks/future_reference.py`) and its own previous latent, z_t = mean of
q(z_t | z_{t-1}, s_{t+1..t+5}) (z_0 = 0 at each episode start, as in training); the decoder
turns (s_t, z_t) into absolute PD targets, which drive the env (the clip's expert env with
absolute targets: the targets pass the action mapper unchanged, clipped to the joint limits).

Scored with the strict evaluation of `services/training/evaluation.py` (the same evenly spaced
starts, falls, horizon) for the one-shot controller and for the clip's expert; Fig. A.1's
"relative performance" is the one-shot normalised return over the expert's (above 1 when the
expert is imperfect), here also the relative survival time. Clips held out of the module's
training test generalisation; the others are in-distribution.
"""
from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from learner.atomic_io import atomic_write_json
from learner.errors import SfvError

SUMMARY_KEYS = ("normalized_return", "fall_rate", "episode_seconds", "joint_rotation_error_rad", "end_effector_error_m", "distance_ratio")


class OneShotPolicy:
    """`mean(obs)` for `evaluate_policy`: reads the env's state, returns the action of the decoder's targets."""

    def __init__(self, env, module, decoder):
        from actors.envs.tasks.future_reference import FutureReference

        if env.actions.residual:
            raise SfvError("one-shot: the env must take absolute targets (residual_action_scale None)")
        self.env, self.module, self.decoder = env, module, decoder
        self.future = FutureReference(env.track, env.humanoid)
        self.proprio = np.zeros((1, decoder.proprio_dim), np.float32)
        self.features = np.zeros((1, self.future.width), np.float32)
        self.z = np.zeros((1, decoder.latent_dim), np.float32)

    def mean(self, obs: np.ndarray) -> np.ndarray:
        import torch

        env = self.env
        if env.data.time == 0.0:  # reset() just ran (mj_resetData zeroes the time): a new episode
            self.z[:] = 0.0
        self.future(env.data, env.row, env.root_sync.offset, self.proprio[0], self.features[0])
        with torch.no_grad():
            mu, _ = self.module.encode(torch.from_numpy(self.features), torch.from_numpy(self.z))
        self.z[:] = mu.numpy()
        targets = np.clip(self.decoder(self.proprio, self.z), env.actions.lower, env.actions.upper)
        return targets / env.actions.scale

    def act(self, obs: np.ndarray, deterministic: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """The `act` contract of the render and export rollouts (always the deterministic action)."""
        return self.mean(obs), np.zeros(1, np.float32)


def one_shot_env_and_policy(module_dir: str | Path, expert) -> tuple:
    """The clip's env with absolute targets (the expert's other settings) and the one-shot controller on it."""
    from actors.envs.imitation_env import ImitationEnv
    from actors.motion.formats.io import load_motion
    from learner.motor_decoder import LatentDecoder
    from services.motor.training import load_module

    env = ImitationEnv(load_motion(expert.motion), dataclasses.replace(expert.env_config, residual_action_scale=None))
    return env, OneShotPolicy(env, load_module(Path(module_dir)), LatentDecoder.load(module_dir))


def render_one_shot(module_dir: str | Path, experts_dir: str | Path, clip: str, out: Path, seconds: float | None) -> dict:
    """An MP4 of the one-shot controller beside the clip's ghost (`sfv render`'s film)."""
    from services.experts.library import load_expert
    from services.render.movie import RenderConfig, render_policy

    env, policy = one_shot_env_and_policy(module_dir, load_expert(experts_dir, clip, max_batch=1))
    return render_policy(policy, env, out, RenderConfig(seconds=seconds, label=f"one-shot {clip} ({Path(module_dir).name})"))


def evaluate_clip(module_dir: str, experts_dir: str, clip: str, episodes: int) -> dict:
    """Expert and one-shot figures for `clip` (its expert from `experts_dir`, mirrored ones included)."""
    import torch

    from services.experts.library import load_expert
    from services.training.evaluation import evaluate_policy

    torch.set_num_threads(1)
    source = load_expert(experts_dir, clip, max_batch=1)
    expert = evaluate_policy(source, source.make_env(), episodes)
    env, policy = one_shot_env_and_policy(module_dir, source)
    one_shot = evaluate_policy(policy, env, episodes)
    summary = {name: {key: result.get(key) for key in SUMMARY_KEYS} for name, result in (("expert", expert), ("one_shot", one_shot))}
    summary["relative_return"] = one_shot["normalized_return"] / max(expert["normalized_return"], 1e-9)
    summary["relative_survival"] = one_shot["episode_seconds"] / max(expert["episode_seconds"], 1e-9)
    return summary


def one_shot_benchmark(module_dir: Path, experts_dir: Path, clips: list[str], episodes: int, out: Path, progress: bool = True) -> dict:
    """Every clip (Ray tasks), JSON into `out` (+ a bar chart beside it)."""
    import ray
    from tqdm import tqdm

    from services.ray_session import get_results, ray_session

    module_dir = Path(module_dir)
    try:
        module_record = json.loads((module_dir / "config.json").read_text())
    except (OSError, ValueError) as exc:
        raise SfvError(f"{module_dir}: not a motor module directory ({exc})") from None
    held_out = set(module_record.get("held_out", []))
    results = {}
    with ray_session():
        task = ray.remote(num_cpus=1, max_retries=0)(evaluate_clip)
        refs = {task.remote(str(module_dir), str(experts_dir), clip, episodes): clip for clip in clips}
        with tqdm(total=len(refs), unit="clip", desc="one-shot", disable=not progress) as bar:
            while refs:
                ready, _ = ray.wait(list(refs), num_returns=1)
                clip = refs.pop(ready[0])
                results[clip] = get_results(ready)[0] | {"held_out": clip in held_out}
                bar.update()
    record = {"module": str(module_dir), "trained_on": module_record.get("clips"), "held_out": sorted(held_out),
              "episodes": episodes, "clips": {clip: results[clip] for clip in clips}}
    atomic_write_json(out, record, sort_keys=True)
    plot_relative(record, out.with_suffix(".png"))
    return record


def plot_relative(record: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from services.training.curves import save_figure

    clips = list(record["clips"])
    x = np.arange(len(clips))
    fig, ax = plt.subplots(figsize=(1.6 * len(clips) + 2, 3.4), dpi=110)
    for offset, key, label in ((-0.2, "relative_return", "return / expert's"), (0.2, "relative_survival", "survival / expert's")):
        ax.bar(x + offset, [record["clips"][c][key] for c in clips], width=0.38, label=label)
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_xticks(x, [f"{c}\n(held out)" if record["clips"][c]["held_out"] else c for c in clips])
    ax.set_title("one-shot imitation relative to each clip's expert (004 Fig. A.1)", fontsize=9)
    ax.set_ylim(0, 1.3)
    ax.legend(fontsize=8, ncol=2, loc="upper center")
    save_figure(fig, path)
