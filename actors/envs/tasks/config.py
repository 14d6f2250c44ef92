"""Settings of a task environment (NPMP 004 §3.4 and Supp. D; Merel et al. 2019's go-to-target).

One frozen dataclass for both tasks and both action spaces, so a task run's config.json holds
everything a rollout worker, `sfv task eval` and the renderer need to rebuild the env.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from actors.character.humanoid import PhysicsConfig, control_substeps

TASKS = ("go_to", "push_box", "push_box_phased")
ACTION_SPACES = ("latent", "joint")
RANGES = ("target_distance", "speed_range", "box_distance", "box_target_distance", "box_size_scale", "box_mass")


@dataclass(frozen=True)
class TaskEnvConfig:
    task: str = field(default="go_to", metadata={"choices": TASKS, "help": "go_to (a target at a requested speed and heading), push_box, or push_box_phased (004's phases: go to the box, then push it; a sparse reward each)"})
    action: str = field(default="latent", metadata={"choices": ACTION_SPACES, "help": "latent: the policy outputs z for the frozen decoder; joint: absolute exp-map PD targets, from scratch"})
    module: str | None = field(default="pretrained", metadata={"help": "motor module directory (config.json, decoder.npz, decoder.onnx) for --action latent; "
                               "`pretrained`: the module that ships in learner/pretrained/motor_module (its PROVENANCE.md says how it was made)"})
    latent_scale: float = field(default=1.5, metadata={"help": "z = latent_scale x action: the policy's [-1, 1] box maps to +-latent_scale stds "
                                   "(1.5 covers 95 % of where the encoder puts z: docs/motor.md)"})
    latent_directions: int = field(default=8, metadata={"help": "K > 0: the policy outputs K numbers that move z along the module's K principal "
                                   "directions around its posterior centre (at most 16); 0: the whole latent around z = 0 (measured: docs/motor.md)"})
    control_hz: float = field(default=30.0, metadata={"help": "policy (and decoder) queries per second"})
    physics: PhysicsConfig = field(default_factory=PhysicsConfig, metadata={"help": "MuJoCo model settings"})
    slope: float = field(default=0.0, metadata={"help": "the ground's grade (rise over run) along world +x: 0 is the flat floor, 0.15 SFV Fig. 8's 15 % slope "
                         "(actors/arenas/slope.py); on a slope episodes start facing any way, so pushes and walks go up, down and across it, and the "
                         "policy sees the grade in its heading frame"})
    horizon_s: float = field(default=10.0, metadata={"help": "episode length (seconds); the horizon truncates, a fall terminates"})
    start_motion: str = field(default="deepmimic:walk,deepmimic:run", metadata={"help": "episodes start from a random frame of one of these clips "
                              "(comma-separated; poses the experts know), moved to the origin: walk and run frames give starts at 1.3 and 3.6 m/s "
                              "(004 Supp. D starts each phase from its own mocap frames)"})
    # go-to
    target_distance: tuple[float, float] = field(default=(2.0, 5.0), metadata={"help": "go-to: target distance range (m), direction uniform on the circle"})
    speed_range: tuple[float, float] = field(default=(0.8, 2.5), metadata={"help": "go-to: requested speed range (m/s), drawn per target"})
    heading_spread: float = field(default=0.5, metadata={"help": "go-to: requested heading = direction to the target + U(-spread, spread) rad"})
    success_radius: float = field(default=0.5, metadata={"help": "go-to: a target within this many metres of the root is reached; push-box: the box within this of its target"})
    success_bonus: float = field(default=5.0, metadata={"help": "reward on reaching a target (a new target is drawn at once)"})
    # push-box
    box_distance: tuple[float, float] = field(default=(1.0, 2.0), metadata={"help": "push-box: box distance range from the character (m), ahead within +-45 deg"})
    box_target_distance: tuple[float, float] = field(default=(1.0, 2.0), metadata={"help": "push-box: target distance from the box (m), within +-45 deg of the walker-to-box direction"})
    # the phased push-box (actors/envs/tasks/phased_push_box.py)
    push_start_share: float = field(default=0.5, metadata={"help": "phased push-box: share of episodes that start in the push phase, the box just ahead (004 Fig. 8B: starts in every phase)"})
    box_size_scale: tuple[float, float] = field(default=(0.8, 1.2), metadata={"help": "phased push-box: each episode's box half sizes are the arena's (0.25, 0.25, 0.4 m) scaled by U(low, high) per axis"})
    box_mass: tuple[float, float] = field(default=(2.0, 10.0), metadata={"help": "phased push-box: each episode's box mass range (kg)"})
    box_shaping: float = field(default=1.0, metadata={"help": "phased push-box: reward per metre of progress toward the phase's goal (0: the sparse rewards alone)"})

    def __post_init__(self):
        for name in RANGES:
            object.__setattr__(self, name, tuple(float(v) for v in getattr(self, name)))

    @property
    def character(self) -> str:
        """The body the task envs build: the humanoid (the motor module's decoder speaks its joints)."""
        return "humanoid3d"

    @property
    def substeps(self) -> int:
        return control_substeps(self.physics, self.control_hz)

    @property
    def horizon_steps(self) -> int:
        return max(1, int(round(self.horizon_s * self.control_hz)))

    def problems(self) -> list[str]:
        """Every bad setting, as `--flag: fault` lines (the service layer raises them as one SfvError)."""
        out = []
        if self.task not in TASKS:
            out.append(f"task must be one of {', '.join(TASKS)}, got {self.task!r}")
        if self.action not in ACTION_SPACES:
            out.append(f"--action must be one of {', '.join(ACTION_SPACES)}, got {self.action!r}")
        if self.action == "latent" and not self.module:
            out.append("--action latent needs --module MODULE_DIR (a distilled motor module)")
        if not 0.0 <= self.slope <= 1.0:  # NaN fails too
            out.append(f"--slope must lie in [0, 1] (rise over run; 0.15 is a 15 % slope), got {self.slope}")
        if not 0 <= self.latent_directions <= 16:
            out.append(f"--env.latent-directions must be 0-16, got {self.latent_directions}")
        for name in ("latent_scale", "control_hz", "horizon_s", "success_radius"):
            if not getattr(self, name) > 0:
                out.append(f"--{name.replace('_', '-')} must be positive, got {getattr(self, name)}")
        if not any(name.strip() for name in self.start_motion.split(",")):
            out.append("--start-motion must name at least one clip")
        if not 0.0 <= self.push_start_share <= 1.0:
            out.append(f"--env.push-start-share must lie in [0, 1], got {self.push_start_share}")
        if not self.box_shaping >= 0.0:
            out.append(f"--env.box-shaping must be >= 0, got {self.box_shaping}")
        for name in RANGES:
            lo, hi = getattr(self, name)
            if not 0 < lo <= hi:
                out.append(f"--{name.replace('_', '-')} must be 0 < low <= high, got {lo}, {hi}")
        return out
