"""M imitation envs in one process, stepped together for batched policy inference.

Arrays in and out are (M, ...) numpy arrays; an env that finishes is reset at once from the
start source (auto-reset), and its episode's statistics are recorded: return, normalised
return (return over the maximum possible for that episode), length, whether it fell, and
for ASI its initial state, component and discounted return.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from actors.character.characters import character_named
from actors.character.humanoid3d import HUMANOID3D
from actors.envs.core import CoreParts, ImitationCore
from actors.envs.imitation_env import EnvConfig, ImitationEnv, build_body, env_reference
from actors.envs.ground import Ground
from actors.envs.initial_states import BufferedStarts
from actors.envs.terrain_curriculum import TerrainCurriculum
from actors.motion.reference_motion import ReferenceMotion
from actors.motion.reference_track import ReferenceTrack


def other_end(character) -> int:
    """The fall-cause bit of an episode that ended with no fall link on the ground (tracking
    deviation, divergence, movingcam's rules): the bit after the character's links."""
    return 1 << character.num_links


OTHER_END = other_end(HUMANOID3D)  # humanoid3d's; an env's is other_end(env.humanoid.character)


@dataclass
class EpisodeLog:
    """Finished episodes since the last `drain()` (lists while collecting, arrays out)."""

    returns: list = field(default_factory=list)
    normalized_returns: list = field(default_factory=list)
    discounted_returns: list = field(default_factory=list)
    lengths: list = field(default_factory=list)
    fell: list = field(default_factory=list)
    fall_causes: list = field(default_factory=list)  # bitmask: bit i link i on the ground, `other_end` another end (0: no fall)
    components: list = field(default_factory=list)
    initial_states: list = field(default_factory=list)
    terrain_difficulty: list | None = None  # each episode's, on terrain (None: level ground, not logged)
    state_dim: int = 0

    def drain(self) -> dict[str, np.ndarray]:
        out = {k: np.asarray(v, dtype=np.int64 if k in ("components", "fall_causes") else np.float32)
               for k, v in self.__dict__.items() if k not in ("initial_states", "state_dim") and v is not None}
        out["fell"] = out["fell"].astype(bool)
        out["initial_states"] = np.array(self.initial_states, dtype=np.float32).reshape(len(self.initial_states), self.state_dim)
        for v in self.__dict__.values():
            if isinstance(v, list):
                v.clear()
        return out


class VectorImitationEnv(CoreParts):
    def __init__(self, motion: ReferenceMotion, config: EnvConfig, num_envs: int, starts: BufferedStarts, seed: int = 0, gamma: float = 0.95,
                 start_phase_spread: float = 0.0, terrain_start_level: int = 0):
        """`start_phase_spread`: a start that carries a state (ASI's) begins at a phase drawn
        uniformly within this width around the start's own, the state's deviation from the
        reference carried there (`ImitationEnv.reset`'s `state_phase`); the episode log keeps
        the state as drawn, which is what ASI's gradient needs. 0: at the start's phase.
        `terrain_start_level`: the terrain curriculum's level every env starts at (a resumed
        training's; 0: flat ground)."""
        motion = env_reference(motion, config)  # once for the M envs (a clip retargeted or closed here)
        humanoid = build_body(config, motion)  # one compiled model for the M envs (a scene's env copies its own)
        track = ReferenceTrack(motion, humanoid, 1.0 / config.control_hz, config.horizon_s, config.flight_starts,
                               config.start_velocity_median_rows)
        self.envs = [ImitationEnv(motion, config, humanoid, track) for _ in range(num_envs)]
        self.num_envs = num_envs
        self.starts = starts
        self.gamma = gamma
        self.action_dim = self.envs[0].action_space.shape[0]
        self.state_dim = self.envs[0].state_dim
        self.obs_dim = obs_dim = self.envs[0].obs_dim
        self.obs = np.zeros((num_envs, obs_dim), dtype=np.float32)
        self.final_obs = np.zeros((num_envs, obs_dim), dtype=np.float32)
        self.rewards = np.zeros(num_envs, dtype=np.float32)
        self.terminated = np.zeros(num_envs, dtype=bool)
        self.truncated = np.zeros(num_envs, dtype=bool)
        self._ret = np.zeros(num_envs)
        self._disc = np.zeros(num_envs)
        self._discount = np.ones(num_envs)
        self._len = np.zeros(num_envs, dtype=np.int64)
        self._component = np.full(num_envs, -1, dtype=np.int64)
        self._init_state = np.zeros((num_envs, self.state_dim))
        self.episodes = EpisodeLog(state_dim=self.state_dim)
        self._seed = seed
        self._seeded = False
        if not 0.0 <= start_phase_spread <= 1.0:
            raise ValueError(f"start phase spread must lie in [0, 1], got {start_phase_spread}")
        self.start_phase_spread = float(start_phase_spread)
        self._phase_rng = np.random.default_rng([seed, 4])
        self._loop = motion.loop
        self.curriculum: TerrainCurriculum | None = None
        # The env core over the batch: per-env MuJoCo, then one pass of feature maths over all envs.
        first = self.envs[0]
        self.track = track
        # A scene: every env's e and normalised e as rows of one array (the envs write their rows).
        self.scene_reward = first.scene_reward
        self.scene_vectors = np.stack([env.scene_vector for env in self.envs])
        self.scene_obs = np.stack([env.scene_obs for env in self.envs])
        for i, env in enumerate(self.envs):
            env.scene_vector, env.scene_obs = self.scene_vectors[i], self.scene_obs[i]
        ground = None if first.terrain is None else self._use_terrain(first.terrain, config, terrain_start_level)
        self.core = core = ImitationCore(self.envs, humanoid, track, config, first.obs_features_dim, obs_dim, first.scene_vector.size,
                                         first.scene_reward, first.scene_limbs, ground, first.heightmap_dim)
        core.mode.set_obstacles(first.obstacle_geom_ids)
        self._rows = core.rows
        self._fell = core.fell
        self._diverged = core.diverged
        self._obs64 = core.obs64

    def _use_terrain(self, terrain, config: EnvConfig, start_level: int) -> Ground:
        """One `Ground` over the M envs, each env drawing into its rows; the curriculum's levels."""
        ground = Ground.of(terrain, self.num_envs)
        for i, env in enumerate(self.envs):
            env.use_ground(ground.rows(i))
        self.episodes.terrain_difficulty = []
        if config.terrain_curriculum:
            self.curriculum = TerrainCurriculum(self.num_envs, config.terrain_difficulty, config.control_hz, start_level)
            for i, env in enumerate(self.envs):
                env.terrain_difficulty = self.curriculum.difficulty(i)
        return ground

    def terrain_levels(self) -> np.ndarray | None:
        """Each env's terrain-curriculum level now (a copy); None without a curriculum."""
        return None if self.curriculum is None else self.curriculum.levels.copy()

    @property
    def max_reward(self) -> float:
        """The most one control step can earn from the mode's reward (a scene's adds per row)."""
        return self.envs[0].max_reward

    @property
    def rows(self) -> np.ndarray:
        """Each env's current reference row, the frame of its current observation (a view)."""
        return self._rows

    def set_horizon(self, seconds: float | None) -> None:
        """Cap the length of episodes that start from now on (an episode-length curriculum);
        None lifts the cap. Running episodes keep the limit they started with."""
        cap = None if seconds is None else max(1, int(round(seconds * self.envs[0].config.control_hz)))
        for env in self.envs:
            env.horizon_cap_steps = cap

    def reset(self) -> np.ndarray:
        for i in range(self.num_envs):
            self._reset_env(i)
        return self.obs

    def _reset_env(self, i: int) -> None:
        env = self.envs[i]
        phase, component, state = self.starts.take()
        options = {"phase": phase, "init": "state" if state is not None else "rsi"}
        spread = state is not None and self.start_phase_spread > 0
        if state is not None:
            options["state"] = state
        if spread:
            options["state_phase"], options["phase"] = phase, self._spread_phase(phase)
        seed = None if self._seeded else self._seed + i
        env.reset(seed=seed, options=options)
        env.observation_into(self.obs[i])
        self._rows[i] = env.row
        self.root_sync.reset(i, env.data.qpos[:2], env.row)
        self._init_state[i] = state if spread else env.state_vector()
        self._component[i] = component
        self._ret[i] = self._disc[i] = 0.0
        self._discount[i] = 1.0
        self._len[i] = 0
        if i == self.num_envs - 1:
            self._seeded = True

    def _spread_phase(self, phase: float) -> float:
        """A phase uniform within `start_phase_spread` around `phase` (wrapped on a loop,
        clamped to the clip otherwise)."""
        drawn = phase + self.start_phase_spread * (self._phase_rng.random() - 0.5)
        return drawn % 1.0 if self._loop else min(max(drawn, 0.0), 1.0)

    def step(self, actions: np.ndarray):
        """Step every env; returns views of (obs, rewards, terminated, truncated, final_obs).

        `final_obs[i]` is env i's observation after this step even when it was reset
        (the true successor, for bootstrapping a truncated episode); `obs[i]` is the new
        episode's first observation then.
        """
        rewards = self.core.step(actions, self.scene_vectors, self.scene_obs)
        self.rewards[:] = rewards
        self.final_obs[:] = self._obs64
        self._ret += rewards
        self._disc += self._discount * rewards
        self._discount *= self.gamma
        self._len += 1
        self.obs[:] = self.final_obs
        for i, env in enumerate(self.envs):
            self.terminated[i], self.truncated[i] = env.ending(self._fell[i], self._diverged[i])
            if self.terminated[i] or self.truncated[i]:
                self._record(i, bool(self.terminated[i]))
                self._reset_env(i)
        return self.obs, self.rewards, self.terminated, self.truncated, self.final_obs

    def _record(self, i: int, fell: bool) -> None:
        env = self.envs[i]
        max_return = env.max_episode_return()
        log = self.episodes
        log.returns.append(self._ret[i])
        log.normalized_returns.append(self._ret[i] / max_return)
        log.discounted_returns.append(self._disc[i])
        log.lengths.append(self._len[i])
        log.fell.append(fell)
        log.fall_causes.append((env.fall_detector.touching(env.data) or other_end(env.humanoid.character)) if fell else 0)
        log.components.append(self._component[i])
        log.initial_states.append(self._init_state[i].copy())
        if log.terrain_difficulty is not None:
            log.terrain_difficulty.append(env.terrain_difficulty)
            if self.curriculum is not None:
                env.terrain_difficulty = self.curriculum.update(i, fell, int(self._len[i]))
