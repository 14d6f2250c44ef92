"""The env core: B imitation envs stepped, observed, rewarded and ended together.

The gymnasium env (`ImitationEnv`) is a core over a batch of one, the vector env
(`VectorImitationEnv`) one over its M envs; both step through `ImitationCore.step`, which
runs the simulator's stepping loop (`actors/envs/simulator.py`) and then one pass of feature
maths over the batch: the reference rows (re-synchronised to the character at each new
cycle when the mode tracks the root), the mode's reward and termination (`actors/envs/modes/`),
the arena's scene reward, the zero reward of a falling or diverged step, and the
observations (the character's features, the reference roots ahead, the mode's slots and the
scene vector). The envs (duck-typed: `model`, `data`, `row`, `_step`) keep their episodes'
bookkeeping: start, step count, horizon and scene vector.
"""
from __future__ import annotations

import numpy as np

from actors.character.actions import ActionMapper
from actors.character.features import FeatureExtractor, RewardFeatures
from actors.envs.modes import mode_class
from actors.envs.residual_force import WRENCH_DIM, ResidualForce
from actors.envs.reference_obs import ReferenceObservation, ReferencePoseObservation
from actors.envs.root_sync import RootSync
from actors.envs.simulator import MujocoSimulator


class CoreParts:
    """The parts of its `core` an env shows as its own (`ImitationEnv`, `VectorImitationEnv`):
    one definition, so both envs name the same objects the same way."""

    core: "ImitationCore"

    @property
    def features(self) -> FeatureExtractor:
        return self.core.features

    @property
    def actions(self) -> ActionMapper:
        return self.core.actions

    @property
    def mode(self):
        return self.core.mode

    @property
    def root_sync(self) -> RootSync:
        return self.core.root_sync

    @property
    def reference_obs(self) -> ReferenceObservation:
        return self.core.reference_obs

    @property
    def reference_pose_obs(self) -> ReferencePoseObservation:
        return self.core.reference_pose_obs

    def set_residual_strength(self, strength: float | None) -> None:
        """The residual root wrench's strength from now on (a fraction of its full size; None:
        unchanged); nothing without one."""
        if strength is not None and self.core.residual is not None:
            self.core.residual.set_strength(strength)


class ImitationCore:
    def __init__(self, envs, humanoid, track, config, feature_dim: int, obs_dim: int, scene_dim: int, scene_reward, scene_limbs,
                 ground=None, heightmap_dim: int = 0):
        num_envs = len(envs)
        first = envs[0]
        self.envs = envs
        self.num_envs = num_envs
        self.track = track
        self.sim = MujocoSimulator([env.model for env in envs], [env.data for env in envs], config.substeps)
        self.features = FeatureExtractor(humanoid, num_envs)
        character = humanoid.character
        self.actions = ActionMapper(config.action_parameterisation, config.residual_action_scale, character,
                                    character.residual_scale_factors if config.residual_scale_per_joint else None)
        # A residual wrench on the root (actors/envs/residual_force.py): six more action numbers after the joints'.
        self.residual = None
        if config.residual_force > 0:
            self.residual = ResidualForce(config.residual_force, config.residual_force_weight,
                                          float(first.model.body_subtreemass[humanoid.body_ids[0]]), int(humanoid.body_ids[0]), num_envs,
                                          config.residual_force_scale)
        self.joint_action_dim = self.actions.action_dim
        self.action_dim = self.joint_action_dim + (WRENCH_DIM if self.residual is not None else 0)
        self.mode = mode_class(config.mode)(config, track, humanoid, num_envs)
        self.root_sync = RootSync(track, num_envs, config.sync_root_per_cycle and self.mode.tracks_root)
        self.reference_obs = ReferenceObservation(track, num_envs, config.reference_obs_steps if self.mode.tracks_root else ())
        self.reference_pose_obs = ReferencePoseObservation(track, num_envs, config.reference_pose_obs_steps)
        self.target_lead = first.target_lead_steps  # residual actions add to the reference this many steps later
        self.captures = (self.features.capture, *self.mode.captures)
        self.mode.features = self.features  # a mode observing in the character's heading frame reads it (movingcam's path cue)
        self.fall_detector = first.fall_detector
        self.configure(config)
        self.scene_reward = scene_reward
        self.scene_limbs = scene_limbs
        nu = first.model.nu
        self.targets = np.zeros((num_envs, nu))
        self._base = np.zeros((num_envs, nu))  # each env's reference targets for residual actions
        self.rows = np.zeros(num_envs, dtype=np.int64)  # each env's current reference row
        self._next_rows = np.zeros(num_envs, dtype=np.int64)
        self._reference = RewardFeatures.zeros(first.model.nv, num_envs, self.features.reward_shape)  # each env's reference row, per step
        self.fell = np.zeros(num_envs, dtype=bool)
        self.diverged = np.zeros(num_envs, dtype=bool)
        self.terms = np.zeros((num_envs, len(self.mode.term_names)))
        self.obs64 = np.zeros((num_envs, obs_dim))
        # The observation: features (actors/character/features.py), the reference's poses ahead, the scene vector.
        self.obs_features = self.obs64 if obs_dim == feature_dim else self.obs64[:, :feature_dim]  # a view kept: FeatureExtractor caches by identity
        # then a terrain's heightmap (`actors/envs/ground.py`; `ground` None: level ground, nothing of it runs).
        self.ground = ground
        self.scene_obs_start = obs_dim - heightmap_dim - scene_dim
        self.obs_pose = self.obs64[:, feature_dim:self.scene_obs_start]
        self.obs_scene = self.obs64[:, self.scene_obs_start:obs_dim - heightmap_dim]
        self.obs_heightmap = self.obs64[:, obs_dim - heightmap_dim:] if heightmap_dim else None

    def configure(self, config) -> None:
        """The per-step settings of `config` (early termination, zero reward on a fall)."""
        self.early_termination = config.early_termination
        self.zero_reward_on_fall = config.zero_reward_on_fall
        self.fall = self.fall_detector if config.early_termination else None

    def step(self, actions: np.ndarray, scene_vectors: np.ndarray, scene_obs: np.ndarray) -> np.ndarray:
        """One control step of the batch: (B,) rewards; `fell`, `diverged`, `rows` and the
        observations `obs64` are the step's afterwards."""
        rows = self.rows
        base = None
        if self.actions.residual:
            np.add(rows, 1 + self.target_lead, out=self._next_rows)
            np.minimum(self._next_rows, self.track.rows - 1, out=self._next_rows)
            base = np.take(self.track.ctrl, self._next_rows, axis=0, out=self._base)
        joints = self.joint_action_dim
        if self.residual is not None:
            self.residual.take(actions[:, joints:])
        targets = self.actions.targets_batch(actions[:, :joints], self.targets, base)
        self.sim.step(targets, self.fell, self.diverged, self.fall, self.captures, self.residual)
        for i, env in enumerate(self.envs):
            env._step += 1
            rows[i] = env.row
        features = self.features
        yaw = features.heading()
        reference = self.track.features.take(rows, self._reference)
        self.root_sync.apply(rows, features.pos[:, 0, :2], reference)
        roots = self.reference_obs.gather(rows, self.root_sync.offset)
        sim = features.reward_features(yaw)
        if self.ground is not None:
            self.ground.follow(reference, roots)  # the clip, recorded on the flat, over this ground
            self.ground.ground_end_effectors(sim, features.end_effector_positions())  # hands and feet over the ground under each
        rewards = self.mode.rewards(rows, features, sim, reference, self.terms, self.early_termination)
        if self.residual is not None:
            rewards *= self.residual.reward_factor()
        self.fell |= self.mode.terminated
        if self.scene_reward is not None:
            rewards += self.scene_rewards(rows, scene_vectors)
        rewards[self.diverged] = 0.0
        if self.zero_reward_on_fall:
            rewards[self.fell] = 0.0
        features.observations(self.track.phase[rows], self.obs_features, yaw, roots)
        self.mode.observe(rows, self.obs_features)
        self.reference_pose_obs.write(rows, self.obs_pose)
        self.obs_scene[:] = scene_obs
        if self.obs_heightmap is not None:
            self.ground.heightmap(features.pos[:, 0], yaw, self.obs_heightmap)
        return rewards

    def scene_rewards(self, rows: np.ndarray, e: np.ndarray) -> np.ndarray:
        """002's r_scene of the captured envs at reference `rows`, scenes e (B, 2K)."""
        features = self.features
        return self.scene_reward.batch(rows, features.pos[:, self.scene_limbs], features.root_xmat[:, ::3],
                                       features.com, features.com_vel, e)
