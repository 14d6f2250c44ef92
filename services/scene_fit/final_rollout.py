"""The windows' policies chained in one scene: the simulated motion over the whole clip (002 §5.3).

Policy n controls its control segment (`windows.py`): the first from the clip's first frame,
each next one from the exact simulator state (qpos, qvel) the previous one reached at its
control end. Every policy takes its mean action. A fall ends the run there (`fell_at_frame`);
the motion then covers the frames up to it.

Recorded per clip frame: the character's qpos, its links' positions, its feet's contacts, and
the reference's links (the window's reference, posed by MuJoCo), so that MPJPE and contact
accuracy (`motion_scores.py`) compare like with like.
"""
from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from actors.character.foot_contact import FOOT_LINKS
from actors.envs.imitation_env import ImitationEnv
from actors.motion.reference_motion import ReferenceMotion
from actors.motion.formats.io import load_motion
from services.scene_fit import scene_contract
from services.scene_fit.handover import WindowRollouts, start_episode
from services.scene_fit.motion_scores import contact_accuracy, foot_contacts, mpjpe
from services.scene_fit.window_motion import clip_frame, control_steps


@dataclass
class SimulatedRun:
    qpos: np.ndarray  # (T, nq)
    links: np.ndarray  # (T, L, 3) simulated link positions
    reference_links: np.ndarray  # (T, L, 3)
    contacts: np.ndarray  # (T, 2) simulated foot contacts (right, left)
    window_of_frame: np.ndarray  # (T,) the window whose policy produced each frame
    clip_frames: np.ndarray  # (T,) the clip frame nearest to each simulated frame (control steps)
    fell_at_frame: int | None  # clip frame
    control_hz: float
    reference_qpos: np.ndarray | None = None  # (T, nq) the window's reference row each frame went towards

    def motion(self, name: str, layout) -> ReferenceMotion:
        joint_rot = np.empty((len(self.qpos), layout.num_joints, 4))
        for t, q in enumerate(self.qpos):
            layout.joint_quats_from_qpos(q, joint_rot[t])
        extras = {"simulated_contacts": self.contacts, "window_of_frame": self.window_of_frame, "clip_frame": self.clip_frames}
        return ReferenceMotion(name, np.arange(len(self.qpos)) / self.control_hz, self.qpos[:, 0:3].copy(),
                               self.qpos[:, 3:7].copy(), joint_rot, loop=False, extras=extras)

    def scores(self, reference_contacts: np.ndarray | None) -> dict:
        out = {"mpjpe_mm": 1000.0 * mpjpe(self.reference_links, self.links), "frames": int(len(self.qpos)),
               "fell_at_frame": self.fell_at_frame}
        if reference_contacts is not None:
            out["contact_accuracy"] = contact_accuracy(np.asarray(reference_contacts)[self.clip_frames], self.contacts)
        travel = self.qpos[-1, :2] - self.qpos[0, :2]
        out["root_travel_m"] = float(np.linalg.norm(travel))
        return out


class _Recorder:
    def __init__(self, env: ImitationEnv):
        humanoid = env.humanoid
        self.body_ids = humanoid.body_ids
        self.foot_geoms = humanoid.model.body_geomadr[humanoid.body_ids[list(FOOT_LINKS)]]
        self.ghost = mujoco.MjData(humanoid.model)
        self.rows = {k: [] for k in ("qpos", "links", "reference_links", "contacts", "window", "clip_frame", "reference_qpos")}

    def record(self, env: ImitationEnv, window, frame: int) -> None:
        self.rows["qpos"].append(env.data.qpos.copy())
        self.rows["links"].append(env.data.xpos[self.body_ids].copy())
        self.ghost.qpos[:] = env.track.qpos[env.row]
        self.rows["reference_qpos"].append(self.ghost.qpos.copy())
        mujoco.mj_kinematics(env.model, self.ghost)
        self.rows["reference_links"].append(self.ghost.xpos[self.body_ids].copy())
        self.rows["contacts"].append(foot_contacts(env.model, env.data, self.foot_geoms))
        self.rows["window"].append(window.index)
        self.rows["clip_frame"].append(frame)


def _handover_of(env: ImitationEnv) -> WindowRollouts:
    """The env's present simulator state as a one-episode hand-over."""
    q, v = env.data.qpos.copy()[None], env.data.qvel.copy()[None]
    empty = np.zeros((1, 0))
    return WindowRollouts(empty, empty, env.state_vector()[None], q, v, np.array([True]), np.array([0]))


def final_rollout(runs, e=None, seed: int = 0) -> SimulatedRun:
    """Chain the windows' policies (`sequence.WindowRun`s, trained) with the boxes at clip scene vector e."""
    from learner.policy import NumpyPolicy
    from services.training.run_dir import load_run

    recorder, handover, fell = None, None, None
    control_hz = None
    for run in runs:
        config, weights = load_run(run.train_dir)
        env = ImitationEnv(load_motion(str(run.motion_path)), config.env)
        control_hz = config.env.control_hz
        if e is not None:
            scene_contract.set_env_scene(env, run.window_e(e))
        policy = NumpyPolicy(weights, max_batch=1)
        motion = env.motion
        frame_of = lambda row: clip_frame(run.window, motion, row, control_hz)  # noqa: E731
        obs = start_episode(env, seed, handover, 0)
        if recorder is None:
            recorder = _Recorder(env)
            recorder.record(env, run.window, frame_of(env.row))
        for _ in range(min(control_steps(run.window, motion, control_hz), env.max_episode_steps)):
            action, _ = policy.act(obs[None], deterministic=True)
            obs, _, terminated, truncated, _ = env.step(action[0])
            recorder.record(env, run.window, frame_of(env.row))
            if terminated:
                fell = frame_of(env.row)
                break
            if truncated:
                break
        if fell is not None:
            break
        handover = _handover_of(env)
    rows = {k: np.asarray(v) for k, v in recorder.rows.items()}
    return SimulatedRun(rows["qpos"], rows["links"], rows["reference_links"], rows["contacts"], rows["window"],
                        rows["clip_frame"], fell, control_hz, rows["reference_qpos"])
