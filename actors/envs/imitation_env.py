"""The MuJoCo imitation environment (gymnasium API).

An episode starts from the reference (FSI: first frame; RSI: a random frame), or from a
given full state at a given phase (what the ASI server hands out). Each control step sets
the PD targets (by default the reference's plus a residual action), advances MuJoCo
`physics_hz / control_hz` substeps, and scores the state against the reference with
DeepMimic's imitation reward (`actors/envs/modes/sfv/reward.py`). The episode ends early when a link other
than those the clip allows on the ground touches it (DeepMimic's rule: every link but the
feet, `actors/envs/falls.py`; switchable), with reward 0 on that step, and is truncated at the
horizon: 20 s for looped clips, the clip's end otherwise. The reference's horizontal root is
re-synchronised to the character's at each new cycle of a looped clip (`actors/envs/root_sync.py`).
`EnvConfig.mode = "movingcam"` swaps in the dynamic-camera paper's tracking instead: its
reward, termination and a root-free observation, the root path left to physics
(`actors/envs/modes/movingcam/tracking.py`).

With a scene file (`EnvConfig.scene`, `actors/arenas/scene.py`) the floor carries boxes
(`actors/arenas/boxes.py`), each env owns a copy of the compiled model so that its boxes can
move per episode, the scene vector e normalised by its domain is the observation's last
entries, and the scene reward of 002 (`actors/envs/scene_reward.py`) is added to the imitation
reward. Each episode's e is drawn uniformly in the domain (`scene_randomise`) unless it is
fixed by `set_scene(e)` or given in `reset(options={"scene": e})`.
"""
from __future__ import annotations

import copy
import os
from dataclasses import dataclass, field

import gymnasium as gym
import mujoco
import numpy as np

from actors.arenas import arena_for
from actors.arenas.terrain_generators import check_terrain
from actors.envs.core import CoreParts, ImitationCore
from actors.envs.falls import FallDetector
from actors.envs.ground import HEIGHTMAP_DIM, Ground
from actors.character.features import observation_dim, pose_obs_width, update_kinematics
from actors.character.humanoid import PhysicsConfig, control_substeps
from actors.character.characters import CHARACTER_NAMES, character_named
from actors.character.compiled import CompiledCharacter
from actors.motion.character_reference import reference_for
from actors.motion.loop_closure import close_loop
from actors.motion.reference_motion import ReferenceMotion
from actors.envs.modes import MODE_NAMES, mode_class
from actors.envs.modes.movingcam.tracking import MovingcamConfig
from actors.motion.reference_track import FLIGHT_STARTS, ReferenceTrack
from actors.motion.start_velocity_filter import MEDIAN_ROWS
from actors.envs.modes.sfv.config import SfvConfig
from actors.envs.scene_reward import SCENE_CHARACTERS, SCENE_LIMB_LINKS, SceneReward, SceneRewardConfig
from actors.character.state import StateLayout

INIT_STRATEGIES = ("fsi", "rsi", "state")


@dataclass(frozen=True)
class EnvConfig:
    character: str = field(default="humanoid3d", metadata={"choices": CHARACTER_NAMES, "help": "the body: humanoid3d (DeepMimic's humanoid, SFV's character) or g1 (the Unitree G1, 29 DoF: `sfv models fetch --robot g1`; its motion is a robot motion file, or a humanoid clip retargeted onto it at load)"})
    control_hz: float = field(default=30.0, metadata={"help": "policy queries per second (the paper's 30 Hz)"})
    physics: PhysicsConfig = field(default_factory=PhysicsConfig, metadata={"help": "MuJoCo model settings (physics rate, friction)"})
    horizon_s: float = field(default=20.0, metadata={"help": "episode horizon for looped clips (seconds)"})
    early_termination: bool = field(default=True, metadata={"help": "end the episode when a link the clip does not allow on the ground touches it (DeepMimic: every link but the feet); off for rolls"})
    ground_contact_links: tuple[str, ...] | None = field(default=None, metadata={"help": "links besides the feet that may touch the ground without a fall; None: the clip's DeepMimic setting (cartwheel: hands; crawl: limbs; roll, getups: all)"})
    action_parameterisation: str = field(default="exp_map", metadata={"choices": ("exp_map", "axis_angle"), "help": "exp_map (28-D, DeepMimic's current code and MimicKit) or axis_angle (36-D, SFV's, with a dead point at zero). Walk, ASI, absolute targets, eval NR at 1 M samples: exp_map .23, axis_angle .07 (every episode falls in both)"})
    loop_closure_s: float = field(default=0.0, metadata={"help": "close a looped clip's wrap: its last-to-first pose mismatch blended over this many seconds at each end; 0: the clip as recorded (measured: docs/training.md)"})
    flight_starts: str = field(default="ballistic", metadata={"choices": FLIGHT_STARTS, "help": "velocities of start states in a clip's flight: ballistic (one angular momentum per flight, the centre of mass on a parabola) or reference (the clip's kinematic ones, DeepMimic's; measured: docs/training.md)"})
    start_velocity_median_rows: int = field(default=MEDIAN_ROWS, metadata={"help": "start states' velocities are the median over this many control rows (odd; 1: the clip's own frame differences, DeepMimic's), which removes one-row velocity spikes (measured: docs/training.md)"})
    target_lead_s: float = field(default=1.0 / 15.0, metadata={"help": "residual actions add to the reference pose this long after the step they act towards (PD control lags its target by ~0.1 s); 0: the step's own pose (measured: docs/training.md)"})
    residual_action_scale: float | None = field(default=0.5, metadata={"help": "PD target = reference target of the step acted towards + this (rad) x action (dynamic-camera paper eq. 1); None: absolute targets. Walk, ASI, exp_map, eval NR at 1 M samples: .91 with no falls residual, .23 (all episodes falling) absolute"})
    residual_force: float = field(default=0.0, metadata={"help": "a residual wrench on the root the policy may apply, its largest force per axis as a fraction of body weight (torque: that force x 0.5 m), six more action numbers; the help costs up to residual_force_weight of each step's reward (residual force control, SimPoE; actors/envs/residual_force.py). 0: none, the body alone"})
    residual_force_weight: float = field(default=0.1, metadata={"help": "the share of each step's reward the residual wrench can cost: reward x (1 - w + w exp(-2 |a|^2)) over its six normalised numbers"})
    residual_force_scale: float = field(default=1.0, metadata={"help": "the residual wrench's strength as a fraction of residual_force, the action unchanged: a run that lets the help decay (--residual-force-final) records the strength each checkpoint was trained at, and evaluation, render and export play it there"})
    residual_scale_per_joint: bool = field(default=True, metadata={"help": "scale each joint's residual range by its character's factor (humanoid3d: 1; g1: effort / kp / 0.5); false: residual_action_scale rad on every joint (measured: docs/robots.md)"})
    sync_root_per_cycle: bool = field(default=True, metadata={"help": "move the reference's horizontal root to the character's at each new cycle of a looped clip (DeepMimic sync_char_root_pos)"})
    zero_reward_on_fall: bool = field(default=True, metadata={"help": "the step that ends in a fall earns 0, so falling never pays"})
    init: str = field(default="rsi", metadata={"choices": ("fsi", "rsi"), "help": "start of an episode when reset() is given no state: fsi or rsi"})
    reference_obs_steps: tuple[int, ...] = field(default=(1, 15), metadata={"help": "control steps ahead at which the policy also observes the reference root in its heading frame (MimicKit tar_obs_steps); () for SFV's observation (measured: docs/training.md)"})
    reference_pose_obs_steps: tuple[int, ...] = field(default=(), metadata={"help": "control steps ahead at which the policy also observes the reference's pose: root height and link positions relative to the root in its heading frame, 46 values a step (MimicKit's target observation with key bodies; actors/envs/reference_obs.py); () for none"})
    mode: str = field(default="sfv", metadata={"choices": MODE_NAMES, "help": "sfv: DeepMimic/SFV imitation of the whole reference, root path included; movingcam: the dynamic-camera paper's tracking (002 §5: joint angles, orientation hint, contacts; the root path is left to physics, see actors/envs/modes/movingcam/tracking.py)"})
    sfv: SfvConfig = field(default_factory=SfvConfig, metadata={"help": "the sfv mode's reward and tracking termination"})
    movingcam: MovingcamConfig = field(default_factory=MovingcamConfig, metadata={"help": "the movingcam mode's reward and termination"})
    state_space: str = field(default="rotvec", metadata={"choices": ("rotvec", "qpos"), "help": "coordinates of the initial-state vectors ASI learns a Gaussian over: rotvec (rotations as rotation vectors, 66-D) or qpos (SFV's raw qpos[2:] + qvel, 75-D, quaternion entries perturbed one by one)"})
    scene: str | None = field(default=None, metadata={"help": "scene file (YAML, boxes along the clip's initial heading: actors/arenas/scene.py) put on the floor; the scene vector joins the observation and 002's scene reward the reward; none: the flat floor"})
    scene_check_start_pose: bool = field(default=True, metadata={"help": "refuse a scene file whose box can cover the clip's first frame (off: a scene-fit window that starts at a box)"})
    scene_randomise: bool = field(default=True, metadata={"help": "draw each episode's box positions and heights uniformly in the scene file's domains (002 section 5.3: the value function must generalise over the scene); off: the file's values"})
    terrain: str | None = field(default=None, metadata={"help": "ground that is not level, a height field drawn afresh every episode along the clip's path (actors/arenas/terrain.py, docs/terrain.md): slopes, gaps, steps, rough or mixed (slopes, gaps and steps in 5-8 m sections); the reference's root follows the ground and the policy sees a heightmap; none: the flat floor"})
    terrain_difficulty: float = field(default=1.0, metadata={"help": "how hard the terrain is, in [0, 1]: 0 flat; 1 grades to 15 %, gaps to 40 cm, steps to 15 cm, bumps to 6 cm; with terrain_curriculum the most any env reaches"})
    terrain_curriculum: bool = field(default=True, metadata={"help": "each training env starts on flat ground and moves a level (a tenth of terrain_difficulty) up after an episode of at least 2 s without a fall, down after a fall (the legged-locomotion terrain curriculum); off: every episode at terrain_difficulty"})
    terrain_seed: int = field(default=0, metadata={"help": "seed of the terrains drawn (episode k of sfv eval draws from [seed, k]); eval on seeds training never used"})
    heightmap: bool = field(default=True, metadata={"help": "with a terrain, observe the ground's heights on a 16 x 5 grid around the root in its heading frame (actors/envs/ground.py; 80 numbers at the observation's end); off: the policy walks blind"})

    def __post_init__(self):
        if self.ground_contact_links is not None:
            object.__setattr__(self, "ground_contact_links", tuple(self.ground_contact_links))
        if self.scene is not None:  # absolute: workers, renders and resumes may run elsewhere
            object.__setattr__(self, "scene", os.path.abspath(self.scene))
        object.__setattr__(self, "reference_obs_steps", tuple(int(k) for k in self.reference_obs_steps))
        object.__setattr__(self, "reference_pose_obs_steps", tuple(int(k) for k in self.reference_pose_obs_steps))
        for name, kind in (("sfv", SfvConfig), ("movingcam", MovingcamConfig)):
            if isinstance(getattr(self, name), dict):  # from a saved run config
                object.__setattr__(self, name, kind(**getattr(self, name)))
        character = character_named(self.character)  # ValueError naming the registered characters
        followed = mode_class(self.mode).characters  # ValueError naming the registered modes
        if followed is not None and self.character not in followed:
            raise ValueError(f"env mode {self.mode} follows the {', '.join(followed)} only, not the {self.character}")
        if self.scene is not None and self.character not in SCENE_CHARACTERS:
            raise ValueError(f"scene files and their reward name the {', '.join(SCENE_CHARACTERS)}'s links, not the {self.character}'s")
        unknown = [n for n in self.ground_contact_links or () if n not in character.link_names]
        if unknown:
            raise ValueError(f"ground contact links {unknown} are not links of the {self.character} ({', '.join(character.link_names)})")
        if not (self.residual_force >= 0 and np.isfinite(self.residual_force)):
            raise ValueError(f"residual_force must be a fraction of body weight >= 0, got {self.residual_force}")
        if not 0.0 <= self.residual_force_scale <= 1.0:
            raise ValueError(f"residual_force_scale must be in [0, 1], got {self.residual_force_scale}")
        if not 0.0 <= self.residual_force_weight <= 1.0:
            raise ValueError(f"residual_force_weight must be in [0, 1], got {self.residual_force_weight}")
        if self.flight_starts not in FLIGHT_STARTS:
            raise ValueError(f"flight_starts must be one of {', '.join(FLIGHT_STARTS)}, got {self.flight_starts!r}")
        if self.start_velocity_median_rows < 1 or self.start_velocity_median_rows % 2 == 0:
            raise ValueError(f"start_velocity_median_rows must be an odd number of rows >= 1, got {self.start_velocity_median_rows}")
        check_terrain(self.terrain, self.terrain_difficulty)
        if self.terrain is not None and self.scene is not None:
            raise ValueError("--terrain and --scene do not go together (boxes stand on the flat floor)")
        if not self.loop_closure_s >= 0:
            raise ValueError(f"loop_closure_s must be >= 0, got {self.loop_closure_s}")
        if not self.target_lead_s >= 0:
            raise ValueError(f"target_lead_s must be >= 0, got {self.target_lead_s}")
        if any(k < 0 for k in self.reference_obs_steps + self.reference_pose_obs_steps):
            raise ValueError(f"reference_obs_steps must be >= 0, got {self.reference_obs_steps}")

    @property
    def max_reward(self) -> float:
        """The most one control step can earn (the mode's reward weights, plus 002's scene reward with
        a scene file): the bound on value targets (`ppo.reward_max`)."""
        track = mode_class(self.mode).step_reward_bound(self)
        return track + (SceneRewardConfig().max_reward if self.scene is not None else 0.0)

    @property
    def root_free(self) -> bool:
        """The reference's root path is not tracked (movingcam): no root sync, no reference roots observed."""
        return not mode_class(self.mode).tracks_root

    @property
    def substeps(self) -> int:
        return control_substeps(self.physics, self.control_hz)


def build_body(config: EnvConfig, motion: ReferenceMotion) -> CompiledCharacter:
    """The config's character compiled in the config's arena (a scene's boxes placed along `motion`)."""
    arena = arena_for(config.scene, motion, config.scene_check_start_pose, config.terrain, config.horizon_s)
    return character_named(config.character).build(config.physics, arena)


def env_reference(motion, config: EnvConfig) -> ReferenceMotion:
    """The clip an env imitates: in the config's character's pose space, its loop closed as configured."""
    return close_loop(reference_for(motion, character_named(config.character)), config.loop_closure_s)


class ImitationEnv(CoreParts, gym.Env):
    metadata = {"render_modes": ["rgb_array"], "render_fps": 30}

    def __init__(self, motion, config: EnvConfig = EnvConfig(), humanoid: CompiledCharacter | None = None,
                 track: ReferenceTrack | None = None):
        """`motion`: a reference in any body's pose space (`reference_for` brings it to
        `config.character`'s); `humanoid`, `track`: the built body and its track, when shared."""
        self._config = config
        self.motion = motion = env_reference(motion, config)
        self.humanoid = humanoid or build_body(config, motion)  # the body, whichever character (the name is older than the G1)
        if self.humanoid.character.name != config.character:
            raise ValueError(f"internal: a built {self.humanoid.character.name} for an env of the {config.character}")
        self.arena = self.humanoid.arena
        self.scene = self.arena.scene  # boxes that move per episode (None: nothing moves)
        self.terrain = self.arena.terrain  # a height field drawn per episode (None: level ground)
        # With boxes or terrain each env moves its own (the model is what set_scene and the ground edit).
        own_model = self.scene is not None or self.terrain is not None
        self.model = copy.copy(self.humanoid.model) if own_model else self.humanoid.model
        self.data = mujoco.MjData(self.model)
        self.substeps = config.substeps
        self.track = track or ReferenceTrack(motion, self.humanoid, 1.0 / config.control_hz, config.horizon_s, config.flight_starts,
                                             config.start_velocity_median_rows)
        self.layout = StateLayout(self.humanoid, config.state_space)
        feature_dim = observation_dim(len(config.reference_obs_steps), self.humanoid.character)
        scene_dim = 0 if self.scene is None else self.scene.vector_dim
        # The observation: features (actors/character/features.py), the reference's poses ahead, the scene vector.
        self.scene_obs_start = feature_dim + len(config.reference_pose_obs_steps) * pose_obs_width(self.humanoid.character)
        self.heightmap_dim = HEIGHTMAP_DIM if self.terrain is not None and config.heightmap else 0
        self.obs_dim = self.scene_obs_start + scene_dim + self.heightmap_dim
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (self.obs_dim,), np.float32)
        self.state_dim = self.layout.state_dim
        # The scene vector e of this episode and e over its domain (the observation's tail).
        self.scene_vector = np.zeros(scene_dim)
        self.scene_obs = np.zeros(scene_dim)
        self._fixed_scene: np.ndarray | None = None
        self.scene_reward = None if self.scene is None else SceneReward.for_track(self.track, self.scene, self.arena.frame)
        self.scene_limbs = self.humanoid.body_ids[SCENE_LIMB_LINKS] - 1 if self.scene is not None else None  # rows of FeatureExtractor.pos
        self.fall_detector = FallDetector.for_track(self.humanoid, self.track, config.ground_contact_links)
        self._start = 0
        self._step = 0
        self._max_steps = 1
        # The env core over a batch of one: this env's physics, features, mode and observation.
        self.ground = None if self.terrain is None else Ground.of(self.terrain, 1)  # this env's, a batch of one
        self.terrain_difficulty = config.terrain_difficulty  # a curriculum's current level (the vector env's)
        self._terrain_rng = np.random.default_rng(config.terrain_seed)
        self.core = ImitationCore([self], self.humanoid, self.track, config, feature_dim, self.obs_dim, scene_dim, self.scene_reward, self.scene_limbs,
                                  self.ground, self.heightmap_dim)
        core = self.core
        self.action_space = gym.spaces.Box(-1.0, 1.0, (core.action_dim,), np.float32)  # the joints', then a residual wrench's
        # The boxes' geom ids (empty on the flat floor), for an obstacle-collision termination.
        self.obstacle_geom_ids: tuple[int, ...] = self.arena.obstacle_geom_ids(self.model)
        self.mode.set_obstacles(self.obstacle_geom_ids)
        if self.scene is not None:
            self._fixed_scene = self.scene.vector()  # the file's boxes until the first reset
            self._place_scene(None)
            self._fixed_scene = None
        self._row_buf = core.rows  # this env's reference row, as a batch of one
        self._obs = core.obs64
        self._obs_features = core.obs_features
        self.obs_features_dim = feature_dim
        self._obs_pose = core.obs_pose
        self._terms = core.terms
        self.reward_terms = core.terms[0]  # the same numbers, one env's
        self.horizon_cap_steps: int | None = None  # an episode-length curriculum's current limit
        if self.ground is not None:
            self.ground.regenerate(0, self.model, 0.0, self._terrain_rng)  # flat until the first reset

    def use_ground(self, ground: Ground) -> None:
        """Draw and observe this env's terrain in `ground` (a batch of one over a vector env's rows)."""
        self.ground = self.core.ground = ground

    @property
    def config(self) -> EnvConfig:
        return self._config

    @config.setter
    def config(self, config: EnvConfig) -> None:
        """A new config's per-step settings (early termination, zero reward on a fall) apply from
        the next step; the rest was built from the first."""
        self._config = config
        self.core.configure(config)

    @property
    def movingcam(self):
        """The movingcam mode's tracking state (its targets, contacts, termination); None in other modes."""
        return getattr(self.mode, "tracking", None)

    # ------------------------------------------------------------------------ reset
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """options: {"init": "fsi"|"rsi"|"state", "phase": float, "state": (state_dim,) array,
        "state_phase": float}. With `state_phase` the state was drawn about the reference at
        that phase: its deviation from there is carried onto the reference at `phase`."""
        super().reset(seed=seed)
        options = options or {}
        init = options.get("init", "state" if "state" in options else self.config.init)
        if init not in INIT_STRATEGIES:
            raise ValueError(f"init must be one of {INIT_STRATEGIES}, got {init!r}")
        if init == "fsi":
            start = 0
        elif init == "rsi" and "phase" not in options:
            start = int(self.np_random.integers(self.track.start_steps))
        else:
            start = self.track.start_index(float(options.get("phase", 0.0)))
        self._start, self._step = start, 0
        self._max_steps = self.track.episode_steps(start)
        if self.horizon_cap_steps is not None:  # a curriculum's limit truncates (the value bootstraps), never terminates
            self._max_steps = max(1, min(self._max_steps, self.horizon_cap_steps))
        if self.scene is not None:
            self._place_scene(options.get("scene"))
        if self.ground is not None:
            if seed is not None:  # episode k of an evaluation, or a worker's env: its own terrain stream
                self._terrain_rng = np.random.default_rng([self.config.terrain_seed, seed])
            self.ground.regenerate(0, self.model, self.terrain_difficulty, self._terrain_rng)
        mujoco.mj_resetData(self.model, self.data)
        if init == "state":
            state = np.asarray(options["state"], dtype=np.float64)
            if state.shape != (self.state_dim,) or not np.isfinite(state).all():
                raise ValueError(f"initial state must be {self.state_dim} finite numbers, got shape {state.shape}")
            anchor = self.track.start_index(float(options["state_phase"])) if "state_phase" in options else start
            self.layout.apply_state_vector(state, self.track.qpos[anchor, :2], self.data.qpos, self.data.qvel)
            if anchor != start:
                track = self.track
                self.layout.transfer(self.data.qpos, self.data.qvel, track.qpos[anchor], track.qvel[anchor], track.qpos[start], track.qvel[start])
        else:
            self.data.qpos[:] = self.track.qpos[start]
            self.data.qvel[:] = self.track.qvel[start]
        if self.ground is not None:
            self.ground.lift(0, self.data.qpos)  # the clip was recorded on the flat
        # Hold the current pose as the first PD target so the first substeps do not jerk.
        update_kinematics(self.model, self.data)
        self.root_sync.reset(0, self.data.qpos[:2], start)
        self._row_buf[0] = start
        self.data.ctrl[:] = self.data.actuator_length if self.model.nu else 0.0
        return self._observation(), {"phase": float(self.track.phase[start]), "start_step": start}

    # ------------------------------------------------------------------------- step
    def reference_targets(self, row: int) -> np.ndarray:
        """(1, 28) PD targets residual actions add to on the step towards reference `row`: the
        reference's pose `target_lead_s` later (clamped to the table's last row)."""
        row = min(row + self.target_lead_steps, self.track.rows - 1)
        return self.track.ctrl[row:row + 1]

    @property
    def target_lead_steps(self) -> int:
        return int(round(self.config.target_lead_s * self.config.control_hz))

    def step(self, action):
        core = self.core
        reward = float(core.step(np.asarray(action).reshape(1, -1), self.scene_vector[None], self.scene_obs)[0])
        terminated, truncated = self.ending(bool(core.fell[0]), bool(core.diverged[0]))
        return self._obs[0].astype(np.float32), reward, terminated, truncated, {}

    def ending(self, fell: bool, diverged: bool) -> tuple[bool, bool]:
        """(terminated, truncated) after a step: a fall or divergence ends the episode, the
        horizon (or the clip's end) truncates it."""
        terminated = fell or diverged
        return terminated, (not terminated) and self._step >= self._max_steps

    # ------------------------------------------------------------------------ scene
    def set_scene(self, e) -> None:
        """Fix the scene vector e ([along, height] per box) for this and later episodes
        (None: back to the config's per-episode rule). Moves the boxes now."""
        if self.scene is None:
            raise ValueError("set_scene: this env has no scene (EnvConfig.scene is None)")
        self._fixed_scene = None if e is None else self._checked_scene(e)
        self._place_scene(None)

    def _checked_scene(self, e) -> np.ndarray:
        e = np.asarray(e, dtype=np.float64).reshape(-1)
        if e.shape != (self.scene.vector_dim,) or not np.isfinite(e).all():
            raise ValueError(f"a scene vector is {self.scene.vector_dim} finite numbers ([along, height] per box), got shape {e.shape}")
        return e

    def _place_scene(self, given) -> None:
        if given is not None:
            e = self._checked_scene(given)
        elif self._fixed_scene is not None:
            e = self._fixed_scene
        elif self.config.scene_randomise:
            e = self.scene.sample(self.np_random)
        else:
            e = self.scene.vector()
        self.scene_vector[:] = e
        self.scene_obs[:] = self.scene.normalise(e)
        self.arena.set_scene(self.model, e)

    def max_episode_return(self, steps: int | None = None) -> float:
        """The most this episode can earn over its first `steps` steps (default: all): the
        imitation reward's maximum every step, plus the scene reward's where the reference
        touches or flies to a box."""
        steps = self._max_steps if steps is None else steps
        total = self.max_reward * steps
        if self.scene_reward is not None:
            total += float(self.scene_reward.max_rewards[self._start + 1:self._start + 1 + steps].sum())
        return total

    # ---------------------------------------------------------------------- queries
    @property
    def row(self) -> int:
        return self._start + self._step

    @property
    def phase(self) -> float:
        return float(self.track.phase[self.row])

    @property
    def reward_term_names(self) -> tuple[str, ...]:
        """Names of the five numbers in `reward_terms` (the mode's reward terms, for logging)."""
        return self.mode.term_names

    @property
    def max_reward(self) -> float:
        """The most one control step can earn (movingcam: r_track's, plus r_scene's with a scene)."""
        return self.mode.max_reward

    @property
    def max_episode_steps(self) -> int:
        return self._max_steps

    def state_vector(self) -> np.ndarray:
        return self.layout.state_vector(self.data.qpos, self.data.qvel)

    def reference_state_vector(self, row: int) -> np.ndarray:
        return self.layout.state_vector(self.track.qpos[row], self.track.qvel[row])

    def set_reference_state(self, row: int) -> None:
        """Put the character exactly on the reference at a table row, its own velocities (playback)."""
        self.data.qpos[:] = self.track.qpos[row]
        self.data.qvel[:] = self.track.reference_qvel[row]
        update_kinematics(self.model, self.data)

    def reward_at(self, row: int) -> float:
        """Reward of the current simulated state against the reference at `row`."""
        sim = self.features.reward_features_of(self.data)
        rows = np.array([row], dtype=np.int64)
        return self.mode.reward_one(self.data, rows, self.features, sim, self.track.reward_features(row), self._terms)

    # --------------------------------------------------------------------- internals
    def _observation(self) -> np.ndarray:
        return self._observe().astype(np.float32)

    def observation_into(self, out: np.ndarray) -> np.ndarray:
        """Write the observation into a caller's (float32) row."""
        out[:] = self._observe()
        return out

    def _observe(self) -> np.ndarray:
        self._row_buf[0] = self.row
        reference = self.reference_obs.gather(self._row_buf, self.root_sync.offset)
        self.features.observation(self.data, self.track.phase[self.row], self._obs_features, reference)
        self.mode.observe(self._row_buf, self._obs_features)
        self.reference_pose_obs.write(self._row_buf, self._obs_pose)
        self.core.obs_scene[0] = self.scene_obs
        if self.heightmap_dim:
            self.ground.heightmap(self.features.pos[:, 0], self.features.heading(), self.core.obs_heightmap)
        return self._obs[0]
