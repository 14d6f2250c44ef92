"""Settings of one `sfv bench` run."""
from __future__ import annotations

from dataclasses import dataclass, field

from actors.character.humanoid import PhysicsConfig

SUITES = ("env", "worker", "learner", "system", "peer", "pose", "scaling")
NOT_IN_ALL = ("scaling",)  # dozens of training runs: asked for by name only

# The targets (medians), reported next to what was measured.
TARGET_WORKER_OVER_RAW = 0.85
TARGET_OURS_OVER_PEER_1200HZ = 8.0
TARGET_SYSTEM_2W_OVER_RAW = 0.6
TARGET_HEIGHTMAP_OVER_BLIND = 0.85  # issue 49: the heightmap costs at most 15 % of worker steps


@dataclass
class BenchConfig:
    suites: tuple[str, ...] = field(default=SUITES, metadata={"help": "suites to run, in order"})
    quick: bool = field(default=False, metadata={"help": "fewer repetitions, shorter measurements, smaller training budgets (CI, smoke runs)"})
    repeats: int = field(default=7, metadata={"help": "measured repetitions of every variant (after one warm-up)"})
    seconds: float = field(default=2.0, metadata={"help": "length of one timed measurement of a stepping variant"})
    motion: str = field(default="deepmimic:walk", metadata={"help": "reference motion the env and workers imitate"})
    physics_hz: float = field(default=PhysicsConfig().physics_hz, metadata={"help": "physics rate of the env, worker and system suites (the env's default)"})
    envs_per_worker: int = field(default=32, metadata={"help": "M, envs of the rollout worker in the env suite (the training default)"})
    worker_envs: tuple[int, ...] = field(default=(1, 4, 16, 32, 64), metadata={"help": "M values of the worker suite's batching sweep"})
    action_noise: float = field(default=0.1, metadata={"help": "std of the random actions (normalised units) in env and peer stepping: a fresh policy's exploration noise"})
    peer_rates: tuple[float, ...] = field(default=(240.0, 1200.0), metadata={"help": "physics rates of the peer comparison: pybullet DeepMimic's default 240 Hz and the paper's 1.2 kHz"})
    peer_python: str | None = field(default=None, metadata={"help": "interpreter with pybullet_envs + gym 0.26.2 for the peer process (default: this one)"})
    system_workers: tuple[int, ...] = field(default=(1, 2), metadata={"help": "worker counts of the end-to-end training runs (real Ray)"})
    system_runners: tuple[str, ...] = field(default=("ray", "processes"), metadata={"help": "rollout runners of the end-to-end training runs: ray (Ray actors, the cluster's) and processes (spawned processes over pipes, no Ray: the fastest on one small machine)"})
    system_iterations: int = field(default=5, metadata={"help": "PPO iterations (4096 samples each) per end-to-end training run"})
    reconstruction_repeats: int = field(default=3, metadata={"help": "timed reconstructions of the pose track (each takes tens of seconds on CPU; no warm-up)"})
    pose_video: str | None = field(default=None, metadata={"help": "video for the pose suite (default ../shared's pose2sim cam01.mp4)"})
    pose_models: str | None = field(default=None, metadata={"help": "BlazePose model directory (default: $SFV_POSE_MODELS, the `sfv models fetch` cache, then ../shared's)"})
    seed: int = field(default=0, metadata={"help": "seed of random actions, policy init and learner data"})
    scaling_workers: tuple[int, ...] = field(default=(1, 2), metadata={"help": "worker counts of the scaling suite (the 16-core machine: 1,2,4,8,14)"})
    scaling_runners: tuple[str, ...] = field(default=("processes", "ray"), metadata={"help": "rollout runners of the scaling suite"})
    scaling_iterations: int = field(default=6, metadata={"help": "PPO iterations (4096 samples each) per scaling run; the first is start-up, not measured"})
    scaling_synthetic_workers: tuple[int, ...] = field(default=(2,), metadata={"help": "synthetic (replaying) worker counts of the learner/driver ceiling"})
    scaling_learner_threads: int = field(default=2, metadata={"help": "torch threads of the learner in the ceiling runs"})
    scaling_paced_workers: tuple[int, ...] = field(default=(), metadata={"help": "emulated worker counts (processes that sleep as long as a worker sampling scaling_paced_rate would): how this machine's driver and learner keep up with more workers than it has cores, e.g. 2,4,8,14"})
    scaling_paced_rate: float = field(default=2300.0, metadata={"help": "samples/s of each emulated worker (one core of a bigger machine; a worker here: 2,335)"})
    terrain: str | None = field(default=None, metadata={"help": "worker suite: also M = envs_per_worker envs on this terrain at difficulty 1 (docs/terrain.md), with and without the heightmap, against the flat floor"})

    @classmethod
    def quick_defaults(cls, **overrides) -> BenchConfig:
        base = {"quick": True, "repeats": 3, "seconds": 0.5, "worker_envs": (1, 16), "system_iterations": 2, "reconstruction_repeats": 1,
                "scaling_iterations": 3}
        base.update(overrides)
        return cls(**base)
