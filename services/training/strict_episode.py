"""One strict evaluation episode (`StrictEpisodePlayer`) and the figures over many (`EvaluationTally`).

`services/training/evaluation.py` says what an evaluation is and what each figure means; this
module plays its episodes: the policy's deterministic action, optional pushes on the root, the
clip's strict fall rule after every control step, and the tracking errors of the steps played.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from actors.character.features import RewardFeatures
from actors.envs.falls import FallDetector
from actors.envs.imitation_env import ImitationEnv
from services.training.tracking_error import tracking_errors

PUSH_RECOVERY_S = 1.0  # no push starts later than this before an episode's end
TRAVEL_M = 0.05  # a looped clip whose root moves less than this per cycle has no distance_ratio


@dataclass
class EpisodeOutcome:
    """What one episode did: its normalized return, length, how it ended, and its tracking sums."""
    start_phase: float
    normalized_return: float
    steps: int
    fell: bool
    diverged: bool
    fall_phase: float | None = None
    rotation_sum: float = 0.0
    end_effector_sum: float = 0.0
    error_steps: int = 0
    sim_distance: float = 0.0
    ref_distance: float = 0.0
    pushed_through: bool | None = None  # None: the episode was too short to hold every push


class StrictEpisodePlayer:
    """Plays episodes of `policy` on `env` (early termination off: `detector` judges the falls)."""

    def __init__(self, policy, env: ImitationEnv, detector: FallDetector, push_config=None):
        self.env, self.detector, self.push_config = env, detector, push_config
        track = env.track
        capacity = max(track.horizon_steps, track.start_steps) + 1  # buffers made once
        self.sim_rows = np.empty((capacity, env.features.sim.values.shape[1]))
        self.ref_rows = np.empty(capacity, dtype=np.int64)
        self.sim_values = env.features.sim.values[0]  # written by every env.step
        self.obs_row = np.zeros((1, env.observation_space.shape[0]), np.float32)
        # The deterministic action is the policy's mean: NumpyPolicy / OnnxPolicy.mean skips act()'s
        # log-density (~10 % of an evaluation step); other policies answer act(deterministic=True).
        mean = getattr(policy, "mean", None)
        self.action = mean if callable(mean) else (lambda obs: policy.act(obs, deterministic=True)[0])
        self.root_body = int(env.humanoid.body_ids[0])

    def _schedule(self, seed: int):
        if self.push_config is None:
            return None
        from actors.envs.pushes import PushSchedule

        hz = self.env.config.control_hz
        limit = max(0, self.env.max_episode_steps - int(round(PUSH_RECOVERY_S * hz)))
        return PushSchedule(self.push_config, hz, limit, np.random.default_rng(seed))

    def play(self, seed: int, options: dict) -> EpisodeOutcome:
        from actors.envs.pushes import apply_push

        env, track = self.env, self.env.track
        obs, _ = env.reset(seed=seed, options=options)
        self.obs_row[0] = obs
        start_row, limit, schedule = env.row, env.max_episode_steps, self._schedule(seed)
        total, steps, recorded, fell, diverged, fall_phase = 0.0, 0, 0, False, False, None
        while steps < limit:
            if schedule is not None:
                apply_push(env.data, self.root_body, schedule, steps)
            obs, reward, terminated, truncated, _ = env.step(self.action(self.obs_row)[0])
            steps += 1
            if terminated:  # early termination is off: only a divergence ends an episode here
                diverged = True
                break
            self.sim_rows[recorded], self.ref_rows[recorded] = self.sim_values, env.row
            recorded += 1
            if self.detector(env.data):
                fell, fall_phase = True, float(track.phase[env.row])
                total += 0.0 if env.config.zero_reward_on_fall else reward
                break
            total += reward
            if truncated:
                break
            self.obs_row[0] = obs
        outcome = EpisodeOutcome(float(track.phase[start_row]), total / env.max_episode_return(), steps, fell, diverged,
                                 fall_phase)
        if schedule is not None:
            apply_push(env.data, self.root_body, None, 0)  # no force left behind
            if len(schedule.starts) == self.push_config.count:
                outcome.pushed_through = not (fell or diverged)
        if recorded:
            self._add_tracking(outcome, start_row, recorded)
        return outcome

    def _add_tracking(self, outcome: EpisodeOutcome, start_row: int, recorded: int) -> None:
        track = self.env.track
        sim = RewardFeatures(self.sim_rows[:recorded], self.env.features.reward_shape)
        ref = track.features.take(self.ref_rows[:recorded])
        rotation, end_effector = tracking_errors(sim, ref)
        outcome.rotation_sum, outcome.end_effector_sum = float(rotation.sum()), float(end_effector.sum())
        outcome.error_steps = recorded
        if track.motion.loop:
            outcome.sim_distance = float(np.linalg.norm(sim.root_xy[-1] - track.qpos[start_row, :2]))
            outcome.ref_distance = float(np.linalg.norm(track.qpos[self.ref_rows[recorded - 1], :2] - track.qpos[start_row, :2]))


class EvaluationTally:
    """The evaluation's figures (evaluation.py's docstring) from its episodes' outcomes, in order."""

    def __init__(self, episodes: int, control_hz: float):
        self.hz = control_hz
        self.returns, self.lengths = np.zeros(episodes), np.zeros(episodes)
        self.falls, self.started = np.zeros(episodes, dtype=bool), np.zeros(episodes)
        self.divergences = self.error_steps = self.push_episodes = self.push_survivors = 0
        self.rotation_sum = self.end_effector_sum = self.sim_distance = self.ref_distance = 0.0
        self.fall_phases: list[float] = []
        self.fall_starts: list[dict] = []

    def add(self, k: int, outcome: EpisodeOutcome) -> None:
        self.started[k], self.returns[k], self.lengths[k] = outcome.start_phase, outcome.normalized_return, outcome.steps
        self.falls[k] = outcome.fell or outcome.diverged
        self.divergences += outcome.diverged
        if outcome.fell:
            self.fall_phases.append(outcome.fall_phase)
            self.fall_starts.append({"start_phase": round(outcome.start_phase, 3), "seconds": round(outcome.steps / self.hz, 2)})
        if outcome.pushed_through is not None:
            self.push_episodes += 1
            self.push_survivors += outcome.pushed_through
        if outcome.error_steps:
            self.rotation_sum += outcome.rotation_sum
            self.end_effector_sum += outcome.end_effector_sum
            self.error_steps += outcome.error_steps
            self.sim_distance += outcome.sim_distance
            self.ref_distance += outcome.ref_distance

    def figures(self, motion, push_config=None) -> dict:
        mean_length = float(self.lengths.mean())
        # Only for clips that travel: a looped clip moving its root at least TRAVEL_M per cycle.
        travels = motion.loop and float(np.linalg.norm(motion.cycle_offset[:2])) >= TRAVEL_M
        steps = self.error_steps
        result = {
            "normalized_return": float(self.returns.mean()),
            "normalized_return_std": float(self.returns.std()),
            "fall_rate": float(self.falls.mean()),
            "episode_length": mean_length,
            "episode_seconds": mean_length / self.hz,
            "joint_rotation_error_rad": self.rotation_sum / steps if steps else None,
            "end_effector_error_m": self.end_effector_sum / steps if steps else None,
            "distance_ratio": self.sim_distance / self.ref_distance if travels and self.ref_distance > 0 else None,
            "divergences": int(self.divergences),
            "episodes": len(self.returns),
            "fall_phases": [round(p, 3) for p in sorted(self.fall_phases)],
            "fall_starts": sorted(self.fall_starts, key=lambda f: f["start_phase"]),
            "start_returns": [[round(float(p), 3), round(float(r), 4)] for p, r in zip(self.started, self.returns)],
        }
        if push_config is not None:
            result.update(pushes=int(push_config.count), push_impulse_ns=push_config.impulse, push_duration_s=push_config.duration_s,
                          push_episodes=int(self.push_episodes),
                          push_survival_rate=self.push_survivors / self.push_episodes if self.push_episodes else None)
        return result
