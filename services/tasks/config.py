"""Configuration of one task-policy run (`sfv task`), saved resolved in the run directory.

The fields the training loop reads have the names and meanings of `TrainConfig`'s, so
`services/training/driver.Trainer`'s loop, runners and checkpoints serve task runs unchanged;
the imitation-only parts are switched off (no curriculum, no imitation evaluation, no ASI).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from actors.character.humanoid import PhysicsConfig
from actors.envs.tasks.config import TaskEnvConfig
from learner.config import PPOConfig
from learner.errors import ConfigError, SfvError
from services.training.config import RUNNER_NAMES

# Exploration noise in the policy's [-1, 1] action units. Latent: 0.3 x latent_scale (1.5) = 0.45
# prior standard deviations, white from step to step: white latents of the full prior std keep
# the shipped module's walker up in 97 % of 10-s episodes (bench/results/npmp/levers.json), so
# the untrained policy's noise becomes coordinated movement, not falls (004 §3.4). Joint: the
# imitation default (DeepMimic's small fixed noise); more makes absolute PD targets thrash.
ACTION_STD = {"latent": 0.3, "joint": 0.1}


TASK_HIDDEN = (256, 256)

# Discount of task runs. Imitation's 0.95 is a 0.67 s horizon at 30 Hz: a target 3 m away is
# 2-4 s of walking, and its bonus reached 90 steps later counted .95^90 = .01 of itself, so
# the go-to policies of the first task table (2 M samples, gamma .95) learnt nothing beyond
# the dense heading term (training success flat at .05-.10). At .99 the same bonus counts .40;
# MoCapAct's transfer tasks use .99 too.
TASK_GAMMA = 0.99


def task_ppo(action: str) -> PPOConfig:
    """PPO settings of a task run: the imitation defaults, a longer discount (TASK_GAMMA), task
    rewards unbounded above (a target bonus), exploration noise by action space, and 256-256
    networks: the task policy maps a few task features to a gait command (004 §3.4 uses small
    MLPs before its LSTM), and a quarter of the imitation policy's forward cost leaves the CPU
    to the physics and decoder."""
    return PPOConfig(gamma=TASK_GAMMA, reward_max=None, action_std=ACTION_STD[action], policy_hidden=TASK_HIDDEN, value_hidden=TASK_HIDDEN)


@dataclass
class TaskConfig:
    out: str = field(default="runs/go_to", metadata={"help": "run directory"})
    workers: int = field(default=2, metadata={"help": "rollout workers"})
    envs_per_worker: int = field(default=16, metadata={"help": "envs per worker, one batched policy (and decoder) forward per step"})
    samples: int = field(default=1_000_000, metadata={"help": "stop after this many environment steps"})
    seed: int = field(default=0, metadata={"help": "base seed; worker i uses seed + i"})
    ray_address: str | None = field(default=None, metadata={"help": "Ray cluster to join; local Ray when absent"})
    runner: str = field(default="ray", metadata={"choices": RUNNER_NAMES, "help": "ray, in_process or processes"})
    device: str = field(default="auto", metadata={"help": "torch device of the learner: auto (the GPU when torch sees one, else the CPU), cpu, cuda, cuda:N"})
    torch_threads: int = field(default=0, metadata={"help": "learner's torch threads; 0 = every core"})
    worker_timeout_s: float = field(default=300.0, metadata={"help": "give up on a worker's batch after this long"})
    checkpoint_every: int = field(default=10, metadata={"help": "iterations between checkpoints (and at the end)"})
    keep_checkpoints: int = field(default=3, metadata={"help": "newest checkpoints kept"})
    plot_every: int = field(default=5, metadata={"help": "iterations between learning-curve redraws (0: never)"})
    plot_min_interval_s: float = field(default=30.0, metadata={"help": "and at least this many seconds between redraws"})
    job_id: str | None = field(default=None, metadata={"help": "run id (derived from the run directory)"})
    env: TaskEnvConfig = field(default_factory=TaskEnvConfig)
    ppo: PPOConfig = field(default_factory=lambda: task_ppo("latent"))
    # Imitation-only settings the shared loop reads, fixed off for tasks.
    curriculum_start_s: float = 0.0
    curriculum_samples: int = 1
    eval_every: int = 0
    eval_episodes: int = 1
    max_policy_lag: int = 0  # the shared loop's synchronous collection (its asynchronous one is not measured on tasks)

    @property
    def policy_lag(self) -> int:
        """The lag the shared loop runs with (`TrainConfig.policy_lag`): always synchronous here."""
        return self.max_policy_lag

    def validate(self) -> None:
        problems = list(self.env.problems())
        if self.runner not in RUNNER_NAMES:
            problems.append(f"--runner must be one of {', '.join(RUNNER_NAMES)}, got {self.runner!r}")
        for name in ("workers", "envs_per_worker", "samples", "checkpoint_every", "keep_checkpoints"):
            if getattr(self, name) <= 0:
                problems.append(f"--{name.replace('_', '-')} must be positive, got {getattr(self, name)}")
        if self.torch_threads < 0:
            problems.append(f"--torch-threads must be >= 0, got {self.torch_threads}")
        try:
            self.ppo.validate()
        except ConfigError as exc:
            problems.append(str(exc))
        if problems:
            raise SfvError("task config: " + "; ".join(problems))

    @property
    def steps_per_worker(self) -> int:
        return max(1, -(-self.ppo.batch_size // (self.workers * self.envs_per_worker)))

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "TaskConfig":
        d = dict(d)
        env = dict(d.pop("env", {}))
        env.setdefault("latent_directions", 0)  # a run made before the field existed drove the whole latent
        physics = PhysicsConfig(**env.pop("physics", {}))
        ppo = PPOConfig.from_dict(d.pop("ppo", {}))
        try:
            return cls(**d, env=TaskEnvConfig(physics=physics, **env), ppo=ppo)
        except TypeError as exc:
            raise ConfigError(f"task run config: {exc}") from None
