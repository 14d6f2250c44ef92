"""Configuration of one training run (`sfv train`), saved resolved in the run directory."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from actors.character.humanoid import PhysicsConfig
from actors.envs.imitation_env import EnvConfig
from learner.config import PPOConfig
from learner.errors import ConfigError

INIT_MODES = ("asi", "rsi", "fsi")
RUNNER_NAMES = ("ray", "in_process", "processes")


@dataclass
class TrainConfig:
    motion: str = field(default="deepmimic:walk", metadata={"help": "motion to imitate: a name (deepmimic:walk) or a .npz / DeepMimic / BVH file (any rig, retargeted); with --character g1 also a robot motion file (sfv motion convert CLIP --character g1), a humanoid clip being retargeted onto the G1 at load"})
    out: str = field(default="runs/walk", metadata={"help": "run directory: config, metrics.jsonl, TensorBoard events, checkpoints"})
    workers: int = field(default=2, metadata={"help": "rollout workers (Ray actors, one process each)"})
    envs_per_worker: int = field(default=32, metadata={"help": "envs per worker, stepped together with one batched policy forward (32 amortises the 1024-512 policy: worker at ~0.9 of raw physics vs ~0.8 at 16)"})
    init: str = field(default="asi", metadata={"choices": INIT_MODES, "help": "initial states: asi (learned), rsi (random reference frame) or fsi (first frame)"})
    samples: int = field(default=200_000, metadata={"help": "stop after this many environment steps in total"})
    seed: int = field(default=0, metadata={"help": "base seed; worker i uses seed + i"})
    ray_address: str | None = field(default=None, metadata={"help": "Ray cluster to join ('auto' or host:port); local single-node Ray when absent"})
    asi_address: str | None = field(default=None, metadata={"help": "host:port of a running `sfv asi-server`; an embedded server when absent"})
    asi_host: str = field(default="127.0.0.1", metadata={"help": "interface the embedded ASI server binds (0.0.0.0 only inside a private cluster network)"})
    redis_url: str | None = field(default=None, metadata={"help": "Redis URL for the embedded ASI server's store (in-memory when absent)"})
    asi_tls_ca: str | None = field(default=None, metadata={"help": "PEM root certificate of a TLS `sfv asi-server` (a path readable on every node)"})
    asi_outage_s: float = field(default=30.0, metadata={"help": "seconds a worker keeps retrying an unreachable ASI server for starts before training stops"})
    asi_components: int = field(default=10, metadata={"help": "k, Gaussian components of the ASI distribution"})
    asi_episodes_per_update: int = field(default=2000, metadata={"help": "episodes reported per ASI gradient step (paper: 2000)"})
    asi_initial_std_scale: float = field(default=0.1, metadata={"help": "initial std of every ASI component = this x the clip's per-dimension sample std (paper: 1; measured: docs/training.md)"})
    asi_step_size: float = field(default=0.001, metadata={"help": "ASI step size alpha_rho (paper: 0.001 with --asi-update-rule gradient; with natural it is the step in units of sigma, e.g. 0.1)"})
    asi_update_rule: str = field(default="gradient", metadata={"choices": ("gradient", "natural"), "help": "ASI's update: gradient (the paper's step: it grows as 1/sigma^2 and with the returns' scale; asi/mean_shift_sigma in the metrics says how far it moved) or natural (normalised advantages, Fisher-preconditioned: services/asi/distribution.py natural_step)"})
    asi_phase_spread: float = field(default=0.0, metadata={"help": "spread each ASI start's phase over this fraction of its component's phase bin; 0: the paper's k fixed start phases, 1: every frame a start (measured: docs/training.md)"})
    asi_fall_weighting: float = field(default=0.0, metadata={"help": "beta in [0, 1]: ASI draws component c with p = (1 - beta)/k + beta f_c / sum f, f_c its episodes' running fall rate; 0: the paper's uniform p(phi) (measured: docs/training.md)"})
    job_id: str | None = field(default=None, metadata={"help": "ASI job id; derived from the run directory when absent"})
    checkpoint_every: int = field(default=10, metadata={"help": "iterations between checkpoints (and at the end)"})
    keep_checkpoints: int = field(default=3, metadata={"help": "newest checkpoints kept on disk"})
    runner: str = field(default="ray", metadata={"choices": RUNNER_NAMES, "help": "how rollout workers run: ray (Ray actors, restarted when they die), in_process (this process, no Ray: debugging, CI) or processes (spawned processes over pipes: hosts without Ray)"})
    device: str = field(default="auto", metadata={"help": "torch device of the learner: auto (the GPU when torch sees one, else the CPU), cpu, cuda, cuda:N"})
    torch_threads: int = field(default=0, metadata={"help": "learner's torch CPU threads; 0: the cores the workers leave (at least 1) in the asynchronous loop, every core of this node in the synchronous one, where workers wait while the learner updates (sync, 2 workers on 2 cores: 0.60-0.64 of raw with 2 threads, 0.52 with 1)"})
    max_policy_lag: int = field(default=0, metadata={"help": "0: synchronous, workers wait for each update (bit-reproducible); K >= 1: workers keep sampling with weights up to K updates old while the learner updates (decoupled PPO clipping; 13 % more samples/s on 2 cores, fewer NR per sample on the jump: docs/scaling.md). in_process: always 0"})
    worker_timeout_s: float = field(default=300.0, metadata={"help": "give up on a worker's batch after this long and hand it to another"})
    plot_every: int = field(default=5, metadata={"help": "iterations between redraws of the learning-curve PNG (0: never)"})
    plot_min_interval_s: float = field(default=30.0, metadata={"help": "and at least this many seconds between redraws (each costs ~0.2 s of the loop); the last iteration always redraws"})
    curriculum_start_s: float = field(default=0.5, metadata={"help": "episode-length curriculum: episodes start capped at this many seconds, the cap growing linearly to the horizon over curriculum_samples (DeepMimic: 0.5 s over 32 M); 0: off. Walk, ASI, same seed, eval NR at 1 M samples: .944 with 0.5 s over 1 M, .908 without (both no falls)"})
    curriculum_samples: int = field(default=1_000_000, metadata={"help": "samples over which the curriculum's cap grows to the full horizon"})
    residual_force_final: float = field(default=1.0, metadata={"help": "a help that decays: the residual root wrench's strength (--env.residual-force) at the end, as a fraction; it holds for the first quarter of the samples, falls linearly to this by three quarters, and the last quarter trains, and best.pt is chosen, at it. 1: constant (measured: docs/video.md)"})
    eval_every: int = field(default=500_000, metadata={"help": "samples between deterministic evaluations during training (strict falls, evenly spaced phases; 0: never); figures go to metrics.jsonl (eval/...), TensorBoard and the learning curve"})
    eval_episodes: int = field(default=8, metadata={"help": "episodes per evaluation during training (sfv eval uses 32)"})
    handover_states: str | None = field(default=None, metadata={"help": "a .npz whose `states` start a share of the episodes at the clip's first frame (a scene-fit window after the first: the previous window's policy's states there, 002 section 5.3)"})
    handover_share: float = field(default=0.5, metadata={"help": "share of episodes started from --handover-states"})
    start_from: str | None = field(default=None, metadata={"help": "a run directory (its best.pt) or checkpoint whose policy, value network and normaliser start this training (not its optimiser or samples); a policy with a residual root wrench's six more action numbers gives its joints'; on --resume the run's own checkpoint wins"})
    first_frame_share: float = field(default=0.0, metadata={"help": "share of episodes started at the reference's first frame, the rest from --init's source; 0: off (sfv pipeline: 0.5; measured: docs/training.md)"})
    env: EnvConfig = field(default_factory=EnvConfig)
    ppo: PPOConfig = field(default_factory=PPOConfig)

    @property
    def serial(self) -> bool:
        """Workers in this process (`--serial`, the older name of `--runner in_process`)."""
        return self.runner == "in_process"

    def validate(self) -> None:
        from learner.errors import SfvError

        if self.runner not in RUNNER_NAMES:
            raise SfvError(f"--runner must be one of {', '.join(RUNNER_NAMES)}, got {self.runner!r}")
        if self.init not in INIT_MODES:
            raise SfvError(f"--init must be one of {', '.join(INIT_MODES)}, got {self.init!r}")
        for name in ("workers", "envs_per_worker", "samples", "asi_components", "asi_episodes_per_update", "checkpoint_every",
                     "worker_timeout_s"):
            if getattr(self, name) <= 0:
                raise SfvError(f"--{name.replace('_', '-')} must be positive, got {getattr(self, name)}")
        if self.asi_update_rule not in ("gradient", "natural"):
            raise SfvError(f"--asi-update-rule must be gradient or natural, got {self.asi_update_rule!r}")
        if not 0.0 <= self.asi_fall_weighting <= 1.0:
            raise SfvError(f"--asi-fall-weighting must lie in [0, 1], got {self.asi_fall_weighting}")
        if self.asi_tls_ca and not self.asi_address:
            raise SfvError("--asi-tls-ca needs --asi-address: the embedded ASI server does not serve TLS")
        try:
            self.ppo.validate()
        except ConfigError as exc:
            raise SfvError(str(exc)) from None
        if self.max_policy_lag < 0:
            raise SfvError(f"--max-policy-lag must be >= 0 (0: synchronous), got {self.max_policy_lag}")
        if self.torch_threads < 0:
            raise SfvError(f"--torch-threads must be >= 0 (0: every core), got {self.torch_threads}")
        if not self.asi_initial_std_scale > 0:
            raise SfvError(f"--asi-std-scale must be positive, got {self.asi_initial_std_scale}")
        if not 0.0 <= self.residual_force_final <= 1.0:
            raise SfvError(f"--residual-force-final must be in [0, 1], got {self.residual_force_final}")
        if self.curriculum_start_s < 0 or self.curriculum_samples <= 0:
            raise SfvError(f"--curriculum-start-s must be >= 0 and --curriculum-samples positive, got {self.curriculum_start_s}, {self.curriculum_samples}")
        if self.eval_every < 0 or self.eval_episodes <= 0:
            raise SfvError(f"--eval-every must be >= 0 and --eval-episodes positive, got {self.eval_every}, {self.eval_episodes}")
        if not 0.0 <= self.asi_phase_spread <= 1.0:
            raise SfvError(f"--asi-phase-spread must lie in [0, 1], got {self.asi_phase_spread}")
        if not 0.0 <= self.first_frame_share <= 1.0:
            raise SfvError(f"--first-frame-share must lie in [0, 1], got {self.first_frame_share}")
        if not 0.0 <= self.handover_share <= 1.0:
            raise SfvError(f"--handover-share must lie in [0, 1], got {self.handover_share}")
        if self.asi_outage_s < 0:
            raise SfvError(f"--asi-outage-s must be >= 0, got {self.asi_outage_s}")
        self._validate_env()

    def _validate_env(self) -> None:
        from learner.errors import SfvError

        env, physics = self.env, self.env.physics
        if not env.control_hz > 0:
            raise SfvError(f"--env.control-hz must be positive, got {env.control_hz}")
        try:
            env.substeps  # noqa: B018  (the env's own rule: a whole number of physics steps per control step)
        except ValueError:
            raise SfvError(f"--physics-hz must be a positive whole multiple of the {env.control_hz:g} Hz control rate "
                           f"(--env.control-hz), got {physics.physics_hz:g}") from None
        if not env.horizon_s > 0:
            raise SfvError(f"--env.horizon-s must be positive, got {env.horizon_s}")
        for name in ("friction", "armature", "joint_damping"):
            if getattr(physics, name) < 0:
                raise SfvError(f"--env.physics.{name.replace('_', '-')} must be >= 0, got {getattr(physics, name)}")
        if env.residual_action_scale is not None and not env.residual_action_scale > 0:
            raise SfvError(f"--residual-scale must be >= 0 (0: absolute targets), got {env.residual_action_scale}")
        if env.action_parameterisation != "exp_map" and env.residual_action_scale is not None:
            raise SfvError("--action axis_angle needs --residual-scale 0: residual targets are exp-map offsets")

    @property
    def policy_lag(self) -> int:
        """The lag the loop runs with: --max-policy-lag, or 0 with the in-process runner, whose
        workers sample in the learner's own thread, so there is no update to overlap and a lag
        would only cost (and the golden digests need its bits)."""
        return 0 if self.runner == "in_process" else self.max_policy_lag

    @property
    def steps_per_worker(self) -> int:
        """Control steps each worker takes per iteration so that the batch is >= batch_size."""
        envs = self.workers * self.envs_per_worker
        return max(1, -(-self.ppo.batch_size // envs))

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "TrainConfig":
        d = _sfv_mode_settings(_upgrade(dict(d)))
        if d.pop("serial", False) and "runner" not in d:  # written before the runners had names
            d["runner"] = "in_process"
        env = dict(d.pop("env", {}))
        physics = PhysicsConfig(**env.pop("physics", {}))
        ppo = PPOConfig.from_dict(d.pop("ppo", {}))
        try:
            return cls(**d, env=EnvConfig(physics=physics, **env), ppo=ppo)
        except TypeError as exc:  # a config from another version: name the field
            raise ConfigError(f"run config: {exc}") from None


def _sfv_mode_settings(d: dict) -> dict:
    """A run config written before the sfv mode owned its settings keeps its reward and
    tracking termination at `env.reward` / `env.tracking_termination_m`: move them under
    `env.sfv`, where the mode reads them."""
    env = dict(d.get("env", {}))
    if "reward" not in env and "tracking_termination_m" not in env:
        return d
    sfv = dict(env.get("sfv", {}))
    for name in ("reward", "tracking_termination_m"):
        if name in env:
            sfv[name] = env.pop(name)
    env["sfv"] = sfv
    d["env"] = env
    return d


def _upgrade(d: dict) -> dict:
    """A run directory written before DeepMimic's reward, residual actions and strict falls
    became the defaults (its env config has no `residual_action_scale`): fill the new fields
    with the settings that run was trained with, so `sfv eval`, `render`, `export` and
    `--resume` still build its env. (Two feature details changed for every run: end effectors
    are scored by their height above the ground, and the centre of mass's velocity is captured.)"""
    env = dict(d.get("env", {}))
    if env and "target_lead_s" not in env:  # written before the residual base led the reference step
        env["target_lead_s"] = 0.0
        d["env"] = env
    if env and "sfv" not in env and "tracking_termination_m" not in env:  # written before the termination existed
        env["tracking_termination_m"] = 0.0
        d["env"] = env
    if env.get("character") == "g1" and "residual_scale_per_joint" not in env:  # written before the G1's per-joint residual range
        env["residual_scale_per_joint"] = False
        d["env"] = env
    if env and "start_velocity_median_rows" not in env:  # written before start velocities lost their one-row spikes
        env["start_velocity_median_rows"] = 1
        d["env"] = env
    if env and "flight_starts" not in env:  # written before flights' start states were made ballistic
        env["flight_starts"] = "reference"
        d["env"] = env
    if not env or "residual_action_scale" in env:
        return d
    from actors.character.humanoid3d import HUMANOID3D  # the only character of those runs

    d.setdefault("curriculum_start_s", 0.0)
    d.setdefault("asi_initial_std_scale", 1.0)
    d["env"] = env
    env.setdefault("action_parameterisation", "axis_angle")
    env["residual_action_scale"] = None
    env.setdefault("sync_root_per_cycle", False)
    env.setdefault("zero_reward_on_fall", False)
    env.setdefault("state_space", "qpos")
    env.setdefault("reference_obs_steps", ())
    # The old rule: only the root, chest and neck touching the ground was a fall.
    env.setdefault("ground_contact_links", tuple(n for n in HUMANOID3D.link_names if n not in ("root", "chest", "neck")))
    reward = dict(env.get("reward", {}))
    if "form" not in reward:
        reward.update(form="sfv_paper", root_weight=0.0)
        reward.setdefault("pose_weight", 0.65)
        reward.setdefault("velocity_weight", 0.1)
        env["reward"] = reward
    return d
