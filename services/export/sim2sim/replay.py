"""The control loop, the fall rule and the report: one episode from the first frame, written as JSON (package docstring)."""
from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

import mujoco
import numpy as np

from services.export.sim2sim.model import DEFAULT_PHYSICS_HZ, build_model, floor_name
from services.export.sim2sim.observer import Observer, update_kinematics
from services.export.sim2sim.policy import Policy, Sim2SimError, load_policy

FOOT_BAND_M = 0.10  # feet: leaf bodies this close to the lowest body origin in qpos0
FALL_HEIGHT_FRACTION = 0.5  # default fall height: this fraction of the first frame's root height
SATURATED = 1.0 - 1e-6  # |force| at or above this fraction of the effort limit counts as saturated
_BAD_WARNINGS = (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQACC)


# ------------------------------------------------------------------------------ control
class Replay:
    """The policy's control loop on a model (`build_model`): reset to the first frame, observe, step."""

    def __init__(self, policy: Policy, model: mujoco.MjModel, xml: Path | str = "the robot MJCF"):
        meta = policy.meta
        self.policy, self.model, self.data = policy, model, mujoco.MjData(model)
        self.observer = Observer(model, meta, xml)
        action = meta["action"]
        self.scale = np.asarray(action["scale"], dtype=np.float64)
        # A policy trained with a residual root wrench outputs six numbers more; no robot has that
        # actuator, so the replay plays the joints' part alone (one per scale: the body without the help).
        self.wrench_dropped = action.get("residual_wrench") is not None
        self.lead = int(action.get("lead_steps", 0))
        self.residual = action.get("offset") == "reference_targets"
        self.lower, self.upper = (np.asarray(limit, dtype=np.float64) for limit in meta["target_limits"])
        self.reference_targets = np.asarray(meta["reference_track"]["targets"], dtype=np.float64)
        self.initial_qpos = np.asarray(meta["initial_qpos"], dtype=np.float64)
        self.initial_qvel = np.asarray(meta["initial_qvel"], dtype=np.float64)
        self.root_sync = bool(meta["observation_reference"].get("root_sync", False))
        self.control_hz = float(meta["control_hz"])
        self.physics_hz = 1.0 / float(model.opt.timestep)
        self.row = 0
        self.offset = np.zeros(2)

    def reset(self) -> np.ndarray:
        """The reference's first frame; its observation."""
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[:] = self.initial_qpos
        self.data.qvel[:] = self.initial_qvel
        update_kinematics(self.model, self.data)
        self.row = 0
        self.offset = self.data.xpos[self.observer.root, :2] - self.observer.qpos[0, :2]
        return self.observation()

    def observation(self) -> np.ndarray:
        return self.observer.observe(self.data, self.row, self.offset)

    def targets(self, action: np.ndarray) -> np.ndarray:
        """PD targets of an action on the step from the current row (towards row + 1)."""
        offset = self.reference_targets[min(self.row + 1 + self.lead, len(self.reference_targets) - 1)] if self.residual else 0.0
        return np.clip(offset + self.scale * np.clip(action[:len(self.scale)], -1.0, 1.0), self.lower, self.upper)

    def substeps(self) -> int:
        """Physics steps of the control step from the current row."""
        ratio = self.physics_hz / self.control_hz
        return max(1, int(round((self.row + 1) * ratio)) - int(round(self.row * ratio)))

    def step(self, action: np.ndarray, stats: "EpisodeStats | None" = None) -> np.ndarray:
        """Hold the action's targets for one control period; the next observation."""
        self.data.ctrl[:] = self.targets(action)
        for _ in range(self.substeps()):
            mujoco.mj_step(self.model, self.data)
            if stats is not None:
                stats.add(self.data)
        return self.advance()

    def advance(self) -> np.ndarray:
        """After the physics of a control step: the next row, the kinematics, a new cycle's root sync; the observation."""
        self.row += 1
        update_kinematics(self.model, self.data)
        phase = self.observer.phase
        row = min(self.row, self.observer.last_row)
        if self.root_sync and row > 0 and phase[row] < phase[row - 1]:  # a new cycle
            self.offset = self.data.xpos[self.observer.root, :2] - self.observer.qpos[row, :2]
        return self.observation()


class EpisodeStats:
    """Per physics step: |target - joint position| (mean over actuators) and which actuators saturate."""

    def __init__(self, effort_limits: np.ndarray):
        self.limits = np.asarray(effort_limits, dtype=np.float64) * SATURATED
        self.steps = 0
        self.error_sum = 0.0
        self.saturated = np.zeros(len(self.limits))

    def add(self, data: mujoco.MjData) -> None:
        self.steps += 1
        self.error_sum += float(np.mean(np.abs(data.ctrl - data.actuator_length)))
        self.saturated += np.abs(data.actuator_force) >= self.limits


class FallRule:
    """The root's origin below `height` m, a floor contact of a body the clip does not allow, or a
    diverged simulation. The allowed bodies are `allowed` (the file's `ground_contacts`: the feet,
    a cartwheel's hands too) or, where none are given, the feet found in the model (`lowest_leaves`)."""

    def __init__(self, model: mujoco.MjModel, floor: str, root: int, height: float, allowed: tuple[str, ...] | None = None):
        self.model, self.root, self.height = model, root, float(height)
        self.floor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, floor)
        self.from_metadata = allowed is not None
        self.allowed = tuple(allowed) if allowed is not None else lowest_leaves(model)
        ids = {name: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name) for name in self.allowed}
        unknown = [name for name, i in ids.items() if i < 0]
        if unknown:
            raise ValueError(f"allowed floor-contact bodies {unknown} are not bodies of the model")
        self.allowed_ids = set(ids.values())

    def describe(self) -> str:
        which = (f"the bodies the clip allows ({', '.join(self.allowed)}: the file's ground_contacts)" if self.from_metadata else
                 f"the feet ({', '.join(self.allowed)}: the leaf bodies within {FOOT_BAND_M:g} m of the lowest body origin in qpos0)")
        return f"fall: the root body's origin below {self.height:.3g} m, a floor contact of any body but {which}, or a diverged simulation"

    def __call__(self, data: mujoco.MjData) -> str | None:
        """Why this state is a fall (None: it is not)."""
        if not np.isfinite(data.qpos).all() or any(data.warning[w].number for w in _BAD_WARNINGS):
            return "diverged"
        if data.xpos[self.root, 2] < self.height:
            return "root below the fall height"
        geoms = data.contact.geom[:data.ncon]
        for g1, g2 in geoms:
            other = g2 if g1 == self.floor else g1 if g2 == self.floor else -1
            if other >= 0 and self.model.geom_bodyid[other] not in self.allowed_ids:
                return f"{mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_BODY, self.model.geom_bodyid[other])} touched the floor"
        return None


def lowest_leaves(model: mujoco.MjModel) -> tuple[str, ...]:
    """The feet by the model alone: leaf bodies within FOOT_BAND_M of the lowest body origin in qpos0."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    parents = set(model.body_parentid[1:].tolist())
    leaves = [b for b in range(1, model.nbody) if b not in parents]
    lowest = float(np.min(data.xpos[1:, 2]))
    return tuple(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in leaves if data.xpos[b, 2] <= lowest + FOOT_BAND_M)


# ------------------------------------------------------------------------------- report
def run_episode(replay: Replay, fall: FallRule, steps: int) -> dict:
    """One episode from the first frame for at most `steps` control steps."""
    obs = replay.reset()
    stats = EpisodeStats(replay.model.actuator_forcerange[:, 1])
    reason, done = None, 0
    for step in range(1, steps + 1):
        obs = replay.step(replay.policy.act(obs), stats)
        done = step
        reason = fall(replay.data)
        if reason is not None:
            break
    names = [mujoco.mj_id2name(replay.model, mujoco.mjtObj.mjOBJ_ACTUATOR, a) for a in range(replay.model.nu)]
    fractions = stats.saturated / max(stats.steps, 1)
    worst = int(np.argmax(fractions))
    return {"start": "first frame", "control_steps": done, "physics_steps": stats.steps, "seconds_survived": done / replay.control_hz,
            "fell": reason is not None, "fall_reason": reason,
            "mean_joint_target_error_rad": stats.error_sum / max(stats.steps, 1),
            "max_torque_saturation_fraction": float(fractions[worst]), "most_saturated_actuator": names[worst]}


def run_sim2sim(policy_path: str | os.PathLike, robot_xml: str | os.PathLike, physics_hz: float = DEFAULT_PHYSICS_HZ,
                seconds: float = 10.0, json_out: str | os.PathLike | None = None, contacts: str = "training",
                fall_height: float | None = None, feet: tuple[str, ...] | None = None) -> dict:
    """Replay an exported policy on a fresh model of the robot (package docstring); the report, also
    written to `json_out` (atomically) when given."""
    if not seconds > 0:
        raise ValueError(f"seconds must be positive, got {seconds}")
    policy = load_policy(policy_path)
    meta = policy.meta
    model = build_model(meta, robot_xml, physics_hz, contacts)
    replay = Replay(policy, model, robot_xml)
    height = FALL_HEIGHT_FRACTION * replay.initial_qpos[2] if fall_height is None else fall_height
    floor = floor_name(model)
    allowed = feet if feet is not None else meta.get("ground_contacts", {}).get("allowed_bodies")
    try:
        fall = FallRule(model, floor, replay.observer.root, height, allowed)
    except ValueError as exc:
        raise Sim2SimError(f"{policy_path}: ground_contacts: {exc} {robot_xml}") from None
    steps = min(max(1, int(round(seconds * replay.control_hz))), replay.observer.last_row)
    report = {"policy": str(policy.path), "robot_xml": str(robot_xml), "character": meta.get("character"), "motion": meta.get("motion"),
              "physics_hz": replay.physics_hz, "trained_physics_hz": float(meta["physics_hz"]), "control_hz": replay.control_hz,
              "contacts": contacts, "seconds_requested": float(seconds), "seconds_limit": steps / replay.control_hz,
              "fall_rule": fall.describe(), "residual_wrench_dropped": replay.wrench_dropped,
              "episodes": [run_episode(replay, fall, steps)]}
    if json_out is not None:
        write_json_atomic(json_out, report)
    return report


def write_json_atomic(path: str | os.PathLike, obj) -> Path:
    """JSON to a temporary file beside `path` (fsynced, the usual file mode), then renamed onto it."""
    path = Path(path)
    fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as handle:
            json.dump(obj, handle, indent=2)
            handle.write("\n")
            handle.flush()
            os.fsync(handle.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(name, 0o666 & ~umask)  # mkstemp's is 0600
        os.replace(name, path)
    except BaseException:
        Path(name).unlink(missing_ok=True)
        raise
    return path
