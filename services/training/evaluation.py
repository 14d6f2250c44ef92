"""Evaluate a trained policy the same strict way everywhere (`sfv eval`, and during training).

Episodes. The policy acts deterministically (its mean). Episode k of E starts at phase k / E
of the clip (the nearest row of the clip's start grid), from the reference's full state there
(pose and velocities, as FSI does at phase 0), so E episodes cover the clip evenly and the
same E episodes are played every time. Each episode runs to the horizon (20 s for looped
clips, the clip's end otherwise) unless the character falls or the simulation diverges.

Falls. Whatever the environment's own termination setting (training may run with early
termination off, or with a looser rule), the environment is stepped with early termination
off and the clip's *strict* fall rule is checked after every control step
(`FallDetector.for_track(..., strict=True)`: DeepMimic's contact rule, every link but the feet
and the links the clip allows such as the cartwheel's hands, plus a pelvis-height floor of
`actors.envs.falls.MIN_ROOT_HEIGHT`). A strict fall ends the episode (its step earns 0 when the
env's `zero_reward_on_fall` is set); a divergence (MuJoCo reset its state) ends it as a fall.
A policy that kneels, sits or lies still is counted as fallen even when training let it go on.

Figures (one dict):
- normalized_return: the episode's return over the most it could earn (env.max_reward at each
  of its env.max_episode_steps steps), so in [0, 1], a fall forfeiting the rest; the mean over
  episodes, with normalized_return_std.
- fall_rate: fraction of episodes ended by a strict fall or a divergence (divergences: count).
- episode_length (control steps) and episode_seconds: mean survival time.
- joint_rotation_error_rad: mean over every evaluated step and the 12 joints of the angle
  between the character's and the reference's local joint rotation (ball joints 2 acos|<q, q*>|,
  hinges the absolute angle gap); the root's orientation is not a joint.
- end_effector_error_m: mean over steps and the 4 end effectors (ankles, wrists) of the
  distance between the character's and the reference's end-effector positions in each one's
  heading frame (horizontal offset from the root, height above the ground: the reward's).
- distance_ratio (looped clips that travel, >= 5 cm a cycle; else None): the character's
  horizontal root displacement from start to end of each episode over the reference's over the
  same steps, each summed over episodes (1: it travelled as far as the clip; standing still: 0).
- episodes; with pushes: pushes, push_impulse_ns, push_duration_s, push_episodes, push_survival_rate.
- fall_phases: the clip phase (0 at its first frame, 1 at its last) at which each fall happened,
  sorted: falls bunched at one phase name the part of the clip the controller has not learned.
- fall_starts: for each fall, the phase its episode started at and the seconds it lasted, sorted by
  start phase: falls within the first clip cycle from starts bunched between the phases training
  starts from say the policy never learned to begin there (ASI's k fixed phases), not that it
  cannot hold the skill.
- start_returns: each episode's [start phase, normalized return], in episode order: a high
  normalized_return_std with few falls is a run of starts that track poorly, and this names them.
- first_frame (`sfv eval`, clips that do not loop): the episode a user sees first, started at the
  clip's first frame (FSI) and run to the clip's end with the same strict falls and no pushes:
  normalized_return, fell, episode_seconds of clip_seconds, joint_rotation_error_rad,
  end_effector_error_m. An average over phases can hide a controller that falls from the start
  (a short clip's later phases are easy: little of it is left to survive).

Pushes (`pushes=N`, `sfv eval --push N`; the render's push code, `actors/envs/pushes.py`):
each push is an impulse of `push_impulse` N s (default 40 N s: a 45 kg character's speed changes
by ~0.9 m/s) applied to the root (pelvis) body as a constant horizontal force J / T for
T = `push_duration_s` (0.1 s, rounded to whole control steps: 3 at 30 Hz), in a direction drawn
uniformly on the horizontal circle. Timing is spread evenly over the episode: the span after a
0.5 s settling time and before the last `PUSH_RECOVERY_S` (1 s) is cut into N equal slots and
each push starts at a random control step of its slot. Directions and start steps come from
`np.random.default_rng(seed + k)` for episode k, so an evaluation is reproducible.
push_survival_rate is the fraction of the episodes long enough to hold all N pushes
(push_episodes of them) that reached their end without a strict fall (None if none was).
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from actors.envs.falls import FallDetector
from actors.envs.imitation_env import ImitationEnv
from learner.errors import SfvError
from services.training.config import TrainConfig
from services.training.strict_episode import EvaluationTally, StrictEpisodePlayer
from services.training.tracking_error import tracking_errors  # noqa: F401  (this module's metric, used by its callers)

DEFAULT_EPISODES = 32  # sfv eval


# ------------------------------------------------------------------------------ metrics
def start_phases(episodes: int) -> np.ndarray:
    """Episode k of `episodes` starts at phase k / episodes (evenly spaced over the clip)."""
    return np.arange(episodes) / episodes


def weak_starts(start_returns: list, fraction: float = 0.5) -> tuple[float | None, list]:
    """The median start's normalised return and the (phase, return) of the starts scoring under
    `fraction` of it: a mean over phases hides whether a few starts fail outright or all track a
    little worse."""
    if not start_returns:
        return None, []
    scores = sorted(score for _, score in start_returns)
    median = scores[len(scores) // 2]
    return median, [(phase, score) for phase, score in start_returns if score < fraction * median]


def strict_fall_detector(env: ImitationEnv) -> FallDetector:
    """The clip's strict fall rule (contacts + pelvis floor) for this env's humanoid."""
    return FallDetector.for_track(env.humanoid, env.track, env.config.ground_contact_links, strict=True)


def _push_config(pushes: int, push_impulse: float | None, push_duration_s: float | None):
    """The pushes' PushConfig (None without pushes); SfvError in one line for a bad value."""
    if pushes < 0:
        raise SfvError(f"evaluate: pushes must be >= 0, got {pushes}")
    if not pushes:
        return None
    from actors.envs.pushes import PushConfig

    defaults = PushConfig()
    config = PushConfig(count=pushes, impulse=defaults.impulse if push_impulse is None else float(push_impulse),
                        duration_s=defaults.duration_s if push_duration_s is None else float(push_duration_s))
    if not (math.isfinite(config.impulse) and config.impulse >= 0):
        raise SfvError(f"evaluate: push impulse must be a finite number >= 0, got {config.impulse}")
    if not (math.isfinite(config.duration_s) and config.duration_s > 0):
        raise SfvError(f"evaluate: push duration must be positive, got {config.duration_s}")
    return config


def evaluate_policy(policy, env: ImitationEnv, episodes: int, seed: int = 0, pushes: int = 0,
                    push_impulse: float | None = None, push_duration_s: float | None = None,
                    init: str | None = None) -> dict:
    """Run `episodes` deterministic episodes of `policy` (its `mean(obs (1, obs_dim))` when it has
    one, else `act(obs, deterministic=True)`) on `env`; the figures of this module's docstring.

    Episode k starts at phase k / episodes from the reference state; `init` ("fsi" / "rsi")
    instead resets episode k with seed + k and that strategy (how `sfv render` and
    `sfv export` play their episodes). Strict falls are always counted: the env runs with
    early termination off for the duration of the call (its config is restored after).
    `pushes` > 0 pushes the root `pushes` times an episode (impulse `push_impulse` N s, default
    40, over `push_duration_s`, default 0.1 s)."""
    if episodes <= 0:
        raise SfvError(f"evaluate: episodes must be positive, got {episodes}")
    push_config = _push_config(pushes, push_impulse, push_duration_s)
    player = StrictEpisodePlayer(policy, env, strict_fall_detector(env), push_config)
    tally = EvaluationTally(episodes, env.config.control_hz)
    phases = start_phases(episodes)
    saved_config = env.config
    env.config = dataclasses.replace(saved_config, early_termination=False)  # falls are ours to judge
    try:
        for k in range(episodes):
            options = {"init": init} if init is not None else {"init": "rsi", "phase": float(phases[k])}
            tally.add(k, player.play(seed + k, options))
    finally:
        env.config = saved_config
    return tally.figures(env.track.motion, push_config)


def first_frame_episode(policy, env: ImitationEnv, seed: int = 0) -> dict:
    """The strict episode from the clip's first frame to its end (see the module docstring)."""
    one = evaluate_policy(policy, env, 1, seed, init="fsi")
    hz = env.config.control_hz
    return {"normalized_return": one["normalized_return"], "fell": one["fall_rate"] > 0.0,
            "episode_seconds": one["episode_seconds"], "clip_seconds": env.max_episode_steps / hz,
            "joint_rotation_error_rad": one["joint_rotation_error_rad"], "end_effector_error_m": one["end_effector_error_m"]}


# --------------------------------------------------------------------------- runs / CLI
def with_physics_rate(env_config, physics_hz: float, flag: str = "--physics-hz"):
    """The env settings at another physics rate, refused in one line (naming `flag`) unless it
    is a whole multiple of the control rate (the policy acts at the rate it was trained at)."""
    ratio = physics_hz / env_config.control_hz
    if ratio < 1 or abs(ratio - round(ratio)) > 1e-9:
        raise SfvError(f"{flag} {physics_hz:g} must be a whole multiple of the run's control rate {env_config.control_hz:g} Hz")
    return dataclasses.replace(env_config, physics=dataclasses.replace(env_config.physics, physics_hz=float(physics_hz)))


def make_eval_env(motion, env_config) -> ImitationEnv:
    """An env for evaluation: the training settings with early termination off (the strict
    fall rule is applied by `evaluate_policy`)."""
    return ImitationEnv(motion, dataclasses.replace(env_config, early_termination=False))


def evaluate_run(run_dir: str | Path | None, episodes: int = DEFAULT_EPISODES, seed: int = 0, onnx: str | None = None,
                 motion: str | None = None, pushes: int = 0, push_impulse: float | None = None,
                 push_duration_s: float | None = None, checkpoint: str = "best", physics_hz: float | None = None,
                 env_change=None) -> dict:
    """Evaluate a run's best checkpoint (`checkpoint="latest"`: its newest; or an exported ONNX
    policy) on its motion (or `motion`), at the run's physics rate or at `physics_hz`."""
    from threadpoolctl import threadpool_limits

    from services.training.policy_source import load_policy_source

    source = load_policy_source(run_dir, onnx, motion, checkpoint)
    env_config = source.env_config
    if physics_hz is not None:
        env_config = with_physics_rate(env_config, physics_hz)
    if env_change is not None:  # e.g. sfv eval's terrain flags (services/commands/_terrain_args.py)
        env_config = env_change(env_config)
    env = make_eval_env(source.reference(), env_config)
    with threadpool_limits(1, user_api="blas"):  # batch-1 inference: BLAS threads only spin
        result = evaluate_policy(source.policy, env, episodes, seed, pushes, push_impulse, push_duration_s)
        if not env.motion.loop:
            result["first_frame"] = first_frame_episode(source.policy, env, seed)
    result.update(motion=env.motion.name, policy=source.description, physics_hz=env_config.physics.physics_hz)
    if source.checkpoint is not None:
        result["checkpoint"] = source.checkpoint
    return result


class TrainingEvaluator:
    """The periodic evaluation of `sfv train`: every `eval_every` samples and at the end, the
    current policy on `eval_episodes` strict episodes; figures as `eval/...` metrics."""

    KEYS = ("normalized_return", "normalized_return_std", "fall_rate", "episode_length", "episode_seconds",
            "joint_rotation_error_rad", "end_effector_error_m", "distance_ratio", "episodes")

    def __init__(self, config: TrainConfig):
        self.config = config
        self.every = int(config.eval_every)
        self.episodes = int(config.eval_episodes)
        self._env: ImitationEnv | None = None
        self._policy = None

    def due(self, samples_before: int, samples_after: int, last: bool) -> bool:
        """A multiple of eval_every was crossed in this iteration, or it is the last one."""
        if self.every <= 0:
            return False
        return last or samples_after // self.every > samples_before // self.every

    def __call__(self, weights: dict, residual_strength: float | None = None) -> dict:
        import time

        from threadpoolctl import threadpool_limits

        from actors.character.characters import character_named
        from actors.motion.character_reference import load_reference
        from learner.policy import NumpyPolicy

        if self._env is None:
            reference = load_reference(self.config.motion, character_named(self.config.env.character))
            self._env = make_eval_env(reference, self.config.env)
        self._env.set_residual_strength(residual_strength)  # a decaying help: the strength trained at now
        if self._policy is None:
            self._policy = NumpyPolicy(weights, max_batch=1)
        else:
            self._policy.load_weights(weights)
        started = time.perf_counter()
        with threadpool_limits(1, user_api="blas"):  # restored on exit: the learner keeps its threads
            result = evaluate_policy(self._policy, self._env, self.episodes, self.config.seed)
        figures = {f"eval/{key}": result[key] for key in self.KEYS}
        figures["eval/seconds"] = time.perf_counter() - started
        return figures

    @staticmethod
    def summary(samples: int, figures: dict) -> str:
        return (f"eval @ {samples:,} samples: normalised return {figures['eval/normalized_return']:.3f}, "
                f"fall rate {figures['eval/fall_rate']:.2f} ({figures['eval/episodes']} episodes, "
                f"{figures['eval/episode_seconds']:.1f} s survived, {figures['eval/seconds']:.1f} s to evaluate)")
