"""The env's dynamic-camera ("movingcam", 002 §5) tracking mode, for B envs at once.

In this mode (`EnvConfig.mode = "movingcam"`) the root path of the reference is never
tracked: a moving camera destroyed it, and physics fills it in (002 §5.1). What changes in
the env:

- Reward: 002's r_track (`actors/envs/modes/movingcam/reward.py`) against the joint rotations, the
  video's orientation hint and contact flags (`actors/envs/modes/movingcam/targets.py`). The env adds
  the scene reward r_scene (eq. 10-12) on top where it has a scene.
- Termination: 002 §5.2's rules (`actors/envs/modes/movingcam/termination.py`) on top of the clip's fall rule.
- No root sync (there is no root path to sync to) and, in place of MimicKit's future
  reference roots (whose horizontal positions would hand the policy the fake, frozen path),
  the policy observes at each of the same K steps ahead the reference root's *height*
  (horizontal slots 0) and its rotation relative to the reference's current heading
  (`q_h(ref_t)^-1 q_ref(t+k)`: the tilt to come and the turn to make, no path). For a video
  that turn is relative to the camera, so a panning camera's pan enters it; `--reference-obs
  none` leaves the policy with the paper's state (its own body and the phase) only.
- Every motion is treated as root-free, so a plain mocap clip trains in this mode too (its
  hint and contacts computed from the clip, `actors/envs/modes/movingcam/clip_cues.py`).
- Episodes still start on the reference's state (RSI / FSI / ASI). For a root-free motion
  that state has no horizontal root velocity (the video does not say how fast the person
  went), so the character starts each episode mid-pose but horizontally at rest and the
  policy must get going; the paper does not say how it initialises.

Per control step: `capture(i, data)` for each env after its physics (torques, contacts),
then `rewards(...)` once over the batch, then `observe(rows, out)` after the observation.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from actors.character import quaternion as qn
from actors.envs.modes.movingcam.clip_cues import NECK_LINK
from actors.character.features import RewardFeatures, obs_dim
from actors.envs.modes.movingcam.targets import MovingcamTargets
from actors.envs.modes.movingcam.termination import MovingcamTermination, MovingcamTerminationConfig
from actors.envs.modes.movingcam.path_cue import PathCue
from actors.envs.modes.movingcam.reward import MovingcamReward, MovingcamRewardConfig

ENV_MODES = ("sfv", "movingcam")
# Off in the env: its value bound (EnvConfig.max_reward, from the config alone) cannot tell
# whether a motion carries root_path, and a motion without one trains as before, to the bit.
# The moving pipeline turns it on (services/scene_fit/budget.py: 0.2, measured there).
PATH_WEIGHT = 0.0
_OBSTACLE, _WALKER = 1, 2  # geom kinds for the collision rule (walker: links other than the flagged end effectors)


@dataclass(frozen=True)
class MovingcamConfig:
    reward: MovingcamRewardConfig = field(default_factory=MovingcamRewardConfig, metadata={"help": "002 tracking reward weights and scales"})
    termination: MovingcamTerminationConfig = field(default_factory=MovingcamTerminationConfig, metadata={"help": "002 §5.2 early-termination thresholds"})
    hint_min_confidence: float = field(default=0.5, metadata={"help": "orientation-hint frames whose confidence is below this count neither in the reward nor in termination"})
    path_weight: float = field(default=PATH_WEIGHT, metadata={"help": "weight of following the motion's estimated root path (root_path: observed ahead in the heading frame, paid by its confidence; actors/envs/modes/movingcam/path_cue.py); 0: off, as 002"})
    path_scale: float = field(default=2.0, metadata={"help": "alpha of the path term on the squared gap between the centre of mass's horizontal velocity and the path's ((m/s)^2)"})

    def __post_init__(self):
        for name, kind in (("reward", MovingcamRewardConfig), ("termination", MovingcamTerminationConfig)):
            value = getattr(self, name)
            if isinstance(value, dict):  # from a saved run config
                object.__setattr__(self, name, kind(**value))


def reference_observation_table(track, steps: tuple[int, ...]) -> np.ndarray:
    """(rows, 7K): per row the K reference-root heights (as (0, 0, z)) then the K rotations
    relative to the row's own reference heading, in the observation's slot layout."""
    rows = track.rows
    k = len(steps)
    table = np.zeros((rows, 7 * k))
    if not k:
        return table
    ahead = np.minimum(np.arange(rows)[:, None] + np.asarray(steps)[None, :], rows - 1)  # (rows, K)
    root = track.qpos[:, 3:7]
    heading = qn.heading_quat(root)  # (rows, 4)
    rel = qn.quat_mul(qn.quat_conj(heading)[:, None, :], root[ahead])  # (rows, K, 4)
    rel *= np.where(rel[..., :1] < 0, -1.0, 1.0)
    table[:, 2:3 * k:3] = track.qpos[ahead, 2]
    table[:, 3 * k:] = rel.reshape(rows, 4 * k)
    return table


class MovingcamTracking:
    def __init__(self, track, humanoid, config: MovingcamConfig, batch: int, reference_obs_steps: tuple[int, ...]):
        self.config = config
        self.track = track
        self.targets = MovingcamTargets(track, config.hint_min_confidence)
        model = humanoid.model
        e = len(self.targets.contact_links)
        self.reward = MovingcamReward(config.reward, batch, e, model.nu, model.nv - 6)
        self.termination = MovingcamTermination(config.termination, batch)
        self.path = PathCue(track, reference_obs_steps, config.path_weight, config.path_scale, batch)
        self.max_reward = config.reward.max_reward + (self.path.weight if self.path.active else 0.0)
        # Walker geoms: which flagged end effector each belongs to, and which are other links.
        self._geom_contact = np.zeros((model.ngeom, e), dtype=bool)
        self._geom_body = np.zeros(model.ngeom, dtype=bool)
        for link in range(humanoid.character.num_links):
            body = humanoid.body_ids[link]
            geoms = slice(model.body_geomadr[body], model.body_geomadr[body] + model.body_geomnum[body])
            flagged = np.flatnonzero(self.targets.contact_links == link)
            if flagged.size:
                self._geom_contact[geoms, flagged[0]] = True
            else:
                self._geom_body[geoms] = True
        self._geom_obstacle = np.zeros(model.ngeom, dtype=bool)
        self._has_obstacles = False
        # An arena with obstacles names their geoms (`obstacle_geom_names`); a flat floor has none.
        names = tuple(getattr(humanoid.arena, "obstacle_geom_names", ()))
        self.set_obstacles(tuple(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, n) for n in names))
        self._contact_bits = (self._geom_contact * (1 << np.arange(e))).sum(axis=1).tolist()  # per geom: its flag's bit
        self._flag_rows = ((np.arange(1 << e)[:, None] >> np.arange(e)) & 1).astype(bool)  # bit mask -> (E,) flags
        self._inv_limit = 1.0 / np.maximum(model.actuator_forcerange[:, 1], 1e-9)
        self._neck = int(humanoid.body_ids[NECK_LINK]) - 1  # row of FeatureExtractor.pos (bodies 1..15)
        # Per-env captures and per-step buffers.
        self.torque = np.zeros((batch, model.nu))
        self.contacts = np.zeros((batch, e), dtype=bool)
        self.obstacle_hit = np.zeros(batch, dtype=bool)
        self.terminated = self.termination.any
        self._hint = np.zeros(batch)
        self._hint_weight = np.zeros(batch)
        self._flags = np.zeros((batch, e))
        self._up = np.zeros((batch, 3))
        self._tilt = np.zeros(batch)
        self._horizontal = np.zeros(batch)
        self._ref_table = reference_observation_table(track, reference_obs_steps)
        self._ref_rows = np.zeros((batch, self._ref_table.shape[1]))
        ref_start = obs_dim(humanoid.character) - 1  # the reference slots sit before the phase
        self._ref_cols = slice(ref_start, ref_start + self._ref_table.shape[1])
        self._path_slots = (None, None)  # (observation buffer, its path-velocity slots (B, K, 2))

    def set_obstacles(self, geom_ids: tuple[int, ...]) -> None:
        """The scene's obstacle geoms (for the collision rule); () for a flat floor. Set by the env from its
        arena's `obstacle_geom_names` at construction."""
        self._geom_obstacle[:] = False
        self._geom_obstacle[list(geom_ids)] = True
        self._has_obstacles = bool(len(geom_ids))
        self._geom_kind = (self._geom_obstacle * _OBSTACLE + self._geom_body * _WALKER).tolist()

    def capture(self, i: int, data) -> None:
        """Env i's torques and contacts after its physics step."""
        np.multiply(data.actuator_force, self._inv_limit, out=self.torque[i])
        if data.ncon == 0:
            self.contacts[i] = False
            self.obstacle_hit[i] = False
            return
        # A few contacts: OR-ing per-geom bit masks in Python beats numpy's reductions (4 vs 15 us).
        geoms = data.contact.geom.ravel().tolist()
        bits, flags = self._contact_bits, 0
        for g in geoms:
            flags |= bits[g]
        self.contacts[i] = self._flag_rows[flags]
        if self._has_obstacles:
            kinds, hit = self._geom_kind, False
            for a, b in zip(geoms[::2], geoms[1::2]):
                if kinds[a] | kinds[b] == _OBSTACLE | _WALKER:
                    hit = True
                    break
            self.obstacle_hit[i] = hit

    def rewards(self, rows: np.ndarray, features, sim: RewardFeatures, ref: RewardFeatures, terms: np.ndarray,
                check_termination: bool) -> np.ndarray:
        """Rewards (B,) of the envs captured in `features` (a FeatureExtractor) and here, at table
        `rows`: r_track (the env adds a scene's r_scene); `terms` (B, 5) receives
        r_track's terms. Sets `terminated` when `check_termination`."""
        targets, pos, com = self.targets, features.pos, features.com
        np.take(targets.hint, rows, out=self._hint)
        np.take(targets.hint_weight, rows, out=self._hint_weight)
        np.take(targets.contacts, rows, axis=0, out=self._flags)
        up = np.subtract(pos[:, self._neck], pos[:, 0], out=self._up)
        np.hypot(up[:, 0], up[:, 1], out=self._horizontal)
        np.arctan2(self._horizontal, up[:, 2], out=self._tilt)
        rewards = self.reward.batch(sim, ref, self._tilt, self._hint, self._hint_weight, self.contacts, self._flags,
                                    self.torque, terms)
        if self.path.active:
            rewards += self.path.reward(rows, com_velocity=features.com_vel)
        if check_termination:
            self.termination.check(com[:, 2], ref.com[:, 2], self.reward.pose_error, self.reward.orientation_gap, self.obstacle_hit)
        else:
            self.terminated[:] = False
        return rewards

    def observe(self, rows: np.ndarray, out: np.ndarray, features=None) -> None:
        """Write the root-free reference slots of the observations `out` (B, obs_dim); with the path
        cue, the path's velocities ahead into their horizontal slots, turned by `features`' headings."""
        if self._ref_rows.shape[1]:
            np.take(self._ref_table, rows, axis=0, out=self._ref_rows)
            out[:, self._ref_cols] = self._ref_rows
            if self.path.active:
                self.path.observe(rows, features.heading(), self._path_view(out))

    def _path_view(self, out: np.ndarray) -> np.ndarray:
        """(B, K, 2) view of `out`'s reference-root x, y slots (made once per buffer)."""
        if self._path_slots[0] is not out:
            k = self._ref_table.shape[1] // 7
            root = out[:, self._ref_cols.start:self._ref_cols.start + 3 * k].reshape(out.shape[0], k, 3)
            self._path_slots = (out, root[..., :2])
        return self._path_slots[1]
