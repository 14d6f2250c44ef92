"""The movingcam mode: the dynamic-camera paper's tracking (002 section 5), root path left to physics.

Reward, termination and the root-free observation are `MovingcamTracking`'s
(`actors/envs/modes/movingcam/tracking.py`); it captures each env's torques and contacts right
after its physics step."""
from __future__ import annotations

from actors.envs.modes.movingcam.reward import TERM_NAMES
from actors.envs.modes.movingcam.tracking import MovingcamTracking


class MovingcamMode:
    name = "movingcam"
    term_names = TERM_NAMES
    tracks_root = False
    characters = ("humanoid3d",)  # its cues name the humanoid's feet, hands and neck (clip_cues.py)
    features = None  # the core's FeatureExtractor (set by the core): the path cue is observed in its heading frames

    def __init__(self, config, track, humanoid, batch: int):
        self.tracking = MovingcamTracking(track, humanoid, config.movingcam, batch, config.reference_obs_steps)
        self.max_reward = self.tracking.max_reward
        self.terminated = self.tracking.terminated
        self.captures = (self.tracking.capture,)

    @staticmethod
    def step_reward_bound(config) -> float:
        return config.movingcam.reward.max_reward + max(0.0, config.movingcam.path_weight)

    def rewards(self, rows, features, sim, ref, terms, check_termination):
        return self.tracking.rewards(rows, features, sim, ref, terms, check_termination)

    def reward_one(self, data, row_buf, features, sim, ref, terms) -> float:
        self.tracking.capture(0, data)
        return float(self.tracking.rewards(row_buf, features, sim, ref, terms, False)[0])

    def observe(self, rows, out) -> None:
        self.tracking.observe(rows, out, self.features)

    def set_obstacles(self, geom_ids) -> None:
        self.tracking.set_obstacles(geom_ids)
