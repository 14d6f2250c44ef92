"""A sim-to-sim check of an exported policy: the robot runtime's view (issue 25, item 5).

A robot runtime has the ONNX file (`sfv export RUN --onnx`) and the robot's own MJCF, nothing of
the training code; this module is such a runtime in MuJoCo. It imports onnxruntime, mujoco and
numpy only (nothing of `learner`, `actors` or `services.training`: a test checks `sys.modules`),
and reproduces from the file's metadata (`services/export/runtime_metadata.py`) what the env did:

- the model (`build_model`): the raw XML's bodies, joints and geoms; its own actuators removed and
  one MuJoCo position actuator per entry of `joint_order` (`actuator_names`, `actuator_gear`,
  `kp`, `kd`, `effort_limit`; the joint's `armature` and `physics.joint_damping`), a floor plane
  where the XML has none, `physics.integrator` and the timestep 1 / physics_hz (by default
  1 kHz, not the rate it trained at, `physics_hz`); contacts as trained (`physics.floor_contacts`:
  explicit floor pairs with their friction and condim, self-collision off) or, with
  `contacts="xml"`, as the XML declares them;
- the observation (`Observer`), each block of `observation_layout` computed from MuJoCo data as
  its `what` defines it, for the bodies `observation_links`, with the reference rows ahead of
  `observation_reference` read from `reference_track` (root-synchronised per cycle as it says);
- the control (`Replay`): from the reference's first frame (`initial_qpos`, `initial_qvel`), every
  control step (`control_hz`) the observation through the ONNX graph, `target = offset + scale *
  clip(action, -1, 1)` (`action`; offset `reference_track.targets[min(r + 1 + lead_steps, last)]`
  for residual actions), clipped to `target_limits` and held while physics steps at its own rate
  (a control period that is not a whole number of physics steps ends at the nearest one).

The report (`run_sim2sim`) holds one episode from the first frame: the seconds it survived under
the fall rule it names (`FallRule`: the root's origin below a height, by default half its first-frame
height, or a floor contact of any body but the feet, the leaf bodies of the kinematic tree within
10 cm of the lowest body origin in the model's reference configuration qpos0; or a diverged
simulation), the mean |target - joint position| over physics steps and actuators, and the largest
fraction of physics steps any actuator spent at its effort limit; written as JSON atomically.

Metadata keys read (`REQUIRED_KEYS`; a file without one is refused, naming it): sfv_runtime,
joint_order, actuator_names, actuator_gear, kp, kd, effort_limit, armature, target_limits, action,
reference_track, initial_qpos, initial_qvel, control_hz, physics_hz (reported), physics,
observation_layout, observation_links, observation_reference; and, where present, character,
motion (reported) and mode (only `sfv` is replayed).
"""
from __future__ import annotations

import json
import math
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

DEFAULT_PHYSICS_HZ = 1000.0
CONTACT_MODES = ("training", "xml")
REQUIRED_KEYS = ("sfv_runtime", "joint_order", "actuator_names", "actuator_gear", "kp", "kd", "effort_limit", "armature",
                 "target_limits", "action", "reference_track", "initial_qpos", "initial_qvel", "control_hz", "physics_hz",
                 "physics", "observation_layout", "observation_links", "observation_reference")
OPTIONAL_KEYS = ("character", "motion", "mode")
OBSERVED_BLOCKS = ("root_height", "link_positions", "link_rotations", "link_linear_velocities", "link_angular_velocities",
                   "reference_root_positions", "reference_root_rotations", "phase", "reference_poses")
FOOT_BAND_M = 0.10  # feet: leaf bodies this close to the lowest body origin in qpos0
FALL_HEIGHT_FRACTION = 0.5  # default fall height: this fraction of the first frame's root height
SATURATED = 1.0 - 1e-6  # |force| at or above this fraction of the effort limit counts as saturated
FLOOR_NAME = "sim2sim_floor"
_BAD_WARNINGS = (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQACC)


class Sim2SimError(ValueError):
    """A bad input file: the message is one line naming it and what is wrong."""


def _reason(exc: Exception) -> str:
    return f"{type(exc).__name__}: {' '.join(str(exc).split())[:160]}"


# ----------------------------------------------------------------------------- the file
@dataclass(frozen=True)
class Policy:
    """An exported policy: its ONNX session and its runtime metadata (JSON-decoded)."""

    path: Path
    session: object
    input_name: str
    obs_dim: int
    meta: dict

    def act(self, obs: np.ndarray) -> np.ndarray:
        row = np.asarray(obs, dtype=np.float32).reshape(1, -1)
        return np.asarray(self.session.run(None, {self.input_name: row})[0][0], dtype=np.float64)


def load_policy(path: str | os.PathLike) -> Policy:
    """Open an exported policy (Sim2SimError naming the file when it is not one)."""
    import onnxruntime

    path = Path(path)
    if not path.is_file():
        raise Sim2SimError(f"{path}: no such ONNX policy file")
    options = onnxruntime.SessionOptions()
    options.intra_op_num_threads = 1  # batch-1 inference
    try:
        session = onnxruntime.InferenceSession(str(path), sess_options=options, providers=["CPUExecutionProvider"])
    except Exception as exc:  # onnxruntime raises its own exception types
        raise Sim2SimError(f"{path}: not an ONNX model ({_reason(exc)})") from None
    raw = session.get_modelmeta().custom_metadata_map
    missing = [key for key in REQUIRED_KEYS if key not in raw]
    if missing:
        more = f" and {len(missing) - 1} more" if len(missing) > 1 else ""
        raise Sim2SimError(f"{path}: no robot-runtime metadata key {missing[0]}{more} (export it again: sfv export RUN --onnx FILE)")
    meta = {}
    for key in REQUIRED_KEYS + OPTIONAL_KEYS:
        if key in raw:
            try:
                meta[key] = json.loads(raw[key])
            except json.JSONDecodeError:
                raise Sim2SimError(f"{path}: metadata {key} is not JSON") from None
    inputs = session.get_inputs()
    obs_dim = inputs[0].shape[1] if len(inputs) == 1 and len(inputs[0].shape) == 2 else None
    if not isinstance(obs_dim, int):
        raise Sim2SimError(f"{path}: not an sfv policy (one input of shape [batch, observation])")
    _check_metadata(meta, obs_dim, path)
    return Policy(path, session, inputs[0].name, obs_dim, meta)


def _check_metadata(meta: dict, obs_dim: int, path: Path) -> None:
    """What this runtime can replay: the sfv mode, one action per actuator, the blocks it computes."""
    nu = len(meta["joint_order"])
    if meta.get("mode", "sfv") != "sfv":
        raise Sim2SimError(f"{path}: env mode {meta['mode']} rewrites observation slots; sim2sim replays the sfv mode only")
    action = meta["action"]
    if not action.get("elementwise") or int(action.get("dim", -1)) != nu:
        raise Sim2SimError(f"{path}: {action.get('parameterisation')} actions are not one per actuator; sim2sim needs exp_map actions")
    for key in ("actuator_names", "actuator_gear", "kp", "kd", "effort_limit", "armature"):
        if len(meta[key]) != nu:
            raise Sim2SimError(f"{path}: metadata {key} has {len(meta[key])} entries for {nu} actuators")
    unknown = [block["name"] for block in meta["observation_layout"] if block["name"] not in OBSERVED_BLOCKS]
    if unknown:
        raise Sim2SimError(f"{path}: observation block {unknown[0]} is not one sim2sim computes ({', '.join(OBSERVED_BLOCKS)})")
    size = sum(int(block["size"]) for block in meta["observation_layout"])
    if size != obs_dim:
        raise Sim2SimError(f"{path}: observation_layout covers {size} numbers, the graph reads {obs_dim}")


# ---------------------------------------------------------------------------- the model
def build_model(meta: dict, robot_xml: str | os.PathLike, physics_hz: float = DEFAULT_PHYSICS_HZ,
                contacts: str = "training") -> mujoco.MjModel:
    """A fresh model of the robot from its raw MJCF with the metadata's actuators (module docstring)."""
    xml = Path(robot_xml)
    if contacts not in CONTACT_MODES:
        raise ValueError(f"contacts must be one of {CONTACT_MODES}, got {contacts!r}")
    if not physics_hz > 0:
        raise ValueError(f"physics_hz must be positive, got {physics_hz}")
    if not xml.is_file():
        raise Sim2SimError(f"{xml}: no such robot MJCF file")
    try:
        spec = mujoco.MjSpec.from_file(str(xml))
    except Exception as exc:
        raise Sim2SimError(f"{xml}: not a MuJoCo MJCF ({_reason(exc)})") from None
    for actuator in list(spec.actuators):
        spec.delete(actuator)
    _add_actuators(spec, meta, xml)
    floor = _floor(spec, meta)
    if contacts == "training":
        _training_contacts(spec, floor, meta, xml)
    spec.option.timestep = 1.0 / physics_hz
    spec.option.integrator = _integrator(meta["physics"].get("integrator", "implicitfast"), xml)
    try:
        model = spec.compile()
    except Exception as exc:
        raise Sim2SimError(f"{xml}: does not compile with the policy's actuators ({_reason(exc)})") from None
    if (model.nq, model.nv) != (len(meta["initial_qpos"]), len(meta["initial_qvel"])):
        raise Sim2SimError(f"{xml}: qpos / qvel sizes {model.nq} / {model.nv}, the policy's first frame has "
                           f"{len(meta['initial_qpos'])} / {len(meta['initial_qvel'])}")
    return model


def _add_actuators(spec: mujoco.MjSpec, meta: dict, xml: Path) -> None:
    damping = float(meta["physics"].get("joint_damping", 0.0))
    for i, joint_name in enumerate(meta["joint_order"]):
        joint = spec.joint(joint_name)
        if joint is None:
            raise Sim2SimError(f"{xml}: no joint {joint_name} (the policy's joint_order names it)")
        joint.armature = float(meta["armature"][i])
        joint.damping = [damping, *list(joint.damping)[1:]]  # MuJoCo 4: [linear, higher-order terms]
        actuator = spec.add_actuator(name=meta["actuator_names"][i], target=joint_name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        actuator.set_to_position(kp=float(meta["kp"][i]), kv=float(meta["kd"][i]))
        actuator.gear = [float(g) for g in meta["actuator_gear"][i]]
        limit = float(meta["effort_limit"][i])
        actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        actuator.forcerange = [-limit, limit]


def _floor(spec: mujoco.MjSpec, meta: dict) -> str:
    """The name of the XML's ground plane, or of the one added (the trained pairs' friction)."""
    planes = [g for g in spec.worldbody.geoms if g.type == mujoco.mjtGeom.mjGEOM_PLANE]
    if planes:
        if not planes[0].name:
            planes[0].name = FLOOR_NAME
        return planes[0].name
    friction = meta["physics"].get("floor_contacts", {}).get("friction") or [1.0, 1.0, 0.005, 1e-4, 1e-4]
    spec.worldbody.add_geom(name=FLOOR_NAME, type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0.0, 0.0, 0.05],
                            friction=[friction[0], friction[2], friction[3]])
    return FLOOR_NAME


def _training_contacts(spec: mujoco.MjSpec, floor: str, meta: dict, xml: Path) -> None:
    """The trained contact set: no broad phase (self-collision off), one pair per geom with the floor."""
    contacts = meta["physics"].get("floor_contacts", {})
    if not contacts.get("geoms"):
        raise Sim2SimError(f"{xml}: the policy's metadata lists no floor contacts; use contacts 'xml'")
    for geom in spec.geoms:
        geom.contype, geom.conaffinity = 0, 0
    for pair in list(spec.pairs):
        spec.delete(pair)
    for name in contacts["geoms"]:
        if spec.geom(name) is None:
            raise Sim2SimError(f"{xml}: no geom {name} (the policy's floor contacts name it)")
        spec.add_pair(geomname1=floor, geomname2=name, condim=int(contacts.get("condim", 3)),
                      friction=[float(f) for f in contacts["friction"]])


def _integrator(name: str, xml: Path) -> mujoco.mjtIntegrator:
    try:
        return mujoco.mjtIntegrator.__members__[f"mjINT_{name.upper()}"]
    except KeyError:
        raise Sim2SimError(f"{xml}: the policy's integrator {name!r} is not MuJoCo's") from None


def update_kinematics(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """Positions and body velocities of the current qpos / qvel (mj_step leaves them one step behind)."""
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    mujoco.mj_comVel(model, data)


# ---------------------------------------------------------------------- the observation
def _heading(xmat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(Rz(th), conj(q_h)) of a root rotation matrix (9,): th the yaw of its x axis."""
    theta = math.atan2(xmat[3], xmat[0])
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]), np.array([math.cos(theta / 2), 0.0, 0.0, -math.sin(theta / 2)])


def _turned(left: np.ndarray, quats: np.ndarray) -> np.ndarray:
    """left * q (Hamilton) for each row of `quats` (n, 4), w made non-negative."""
    a0, a1, a2, a3 = left
    b0, b1, b2, b3 = quats.T
    out = np.stack([a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3, a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
                    a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1, a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0], axis=1)
    return np.where(out[:, :1] < 0.0, -out, out)


class Observer:
    """The observation of `observation_layout` from MuJoCo data, the reference from `reference_track`."""

    def __init__(self, model: mujoco.MjModel, meta: dict, xml: Path | str = "the robot MJCF"):
        self.model = model
        self.bodies = []
        for name in meta["observation_links"]:
            body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
            if body < 0:
                raise Sim2SimError(f"{xml}: no body {name} (the policy's observation_links name it)")
            self.bodies.append(body)
        self.root = self.bodies[0]
        self.layout = [(b["name"], int(b["start"]), int(b["size"])) for b in meta["observation_layout"]]
        self.dim = sum(size for _, _, size in self.layout)
        reference, track = meta["observation_reference"], meta["reference_track"]
        self.root_steps = np.asarray(reference["root_steps"], dtype=np.int64)
        self.pose_steps = np.asarray(reference["pose_steps"], dtype=np.int64)
        self.qpos = np.asarray(track["qpos"], dtype=np.float64)
        self.phase = np.asarray(track["phase"], dtype=np.float64)
        self.last_row = len(self.phase) - 1
        self._scratch = mujoco.MjData(model)
        self._velocity = np.zeros(6)

    def observe(self, data: mujoco.MjData, row: int, offset: np.ndarray) -> np.ndarray:
        """The observation at reference row `row` of `data` (kinematics up to date), the root-sync `offset` (2,)."""
        yaw, conj = _heading(data.xmat[self.root])
        out = np.zeros(self.dim)
        for name, start, size in self.layout:
            out[start:start + size] = self._block(name, data, row, offset, yaw, conj)
        return out

    def _block(self, name: str, data, row: int, offset, yaw, conj) -> np.ndarray:
        bodies, root = self.bodies, data.xpos[self.root]
        if name == "root_height":
            return root[2:3]
        if name == "link_positions":
            return ((data.xpos[bodies] - root) @ yaw).ravel()
        if name == "link_rotations":
            return _turned(conj, data.xquat[bodies]).ravel()
        if name in ("link_linear_velocities", "link_angular_velocities"):
            return (self._velocities(data, name == "link_angular_velocities") @ yaw).ravel()
        rows = np.minimum(row + self.root_steps, self.last_row)
        if name == "reference_root_positions":
            positions = self.qpos[rows, 0:3].copy()
            positions[:, :2] += offset
            return ((positions - root) @ yaw).ravel()
        if name == "reference_root_rotations":
            return _turned(conj, self.qpos[rows, 3:7]).ravel()
        if name == "phase":
            return self.phase[min(row, self.last_row):][:1]
        return np.concatenate([self._reference_pose(min(row + k, self.last_row)) for k in self.pose_steps])  # reference_poses

    def _velocities(self, data, angular: bool) -> np.ndarray:
        """(links, 3) each body origin's world angular or linear velocity."""
        rows = []
        for body in self.bodies:
            mujoco.mj_objectVelocity(self.model, data, mujoco.mjtObj.mjOBJ_XBODY, body, self._velocity, 0)  # XBODY: at xpos, not the inertial frame
            rows.append(self._velocity[:3].copy() if angular else self._velocity[3:].copy())
        return np.array(rows)

    def _reference_pose(self, row: int) -> np.ndarray:
        """The reference pose of a row as the policy sees its own: root height, link positions in its heading frame."""
        scratch = self._scratch
        scratch.qpos[:] = self.qpos[row]
        mujoco.mj_kinematics(self.model, scratch)
        yaw, _ = _heading(scratch.xmat[self.root])
        root = scratch.xpos[self.root]
        return np.concatenate([root[2:3], ((scratch.xpos[self.bodies] - root) @ yaw).ravel()])


# ------------------------------------------------------------------------------ control
class Replay:
    """The policy's control loop on a model (`build_model`): reset to the first frame, observe, step."""

    def __init__(self, policy: Policy, model: mujoco.MjModel, xml: Path | str = "the robot MJCF"):
        meta = policy.meta
        self.policy, self.model, self.data = policy, model, mujoco.MjData(model)
        self.observer = Observer(model, meta, xml)
        action = meta["action"]
        self.scale = np.asarray(action["scale"], dtype=np.float64)
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
        return np.clip(offset + self.scale * np.clip(action, -1.0, 1.0), self.lower, self.upper)

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
    """The root's origin below `height` m, a floor contact of a body but the feet, or a diverged simulation."""

    def __init__(self, model: mujoco.MjModel, floor: str, root: int, height: float, feet: tuple[str, ...] | None = None):
        self.model, self.root, self.height = model, root, float(height)
        self.floor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, floor)
        self.feet = tuple(feet) if feet is not None else lowest_leaves(model)
        self.foot_ids = {mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name) for name in self.feet}

    def describe(self) -> str:
        return (f"fall: the root body's origin below {self.height:.3g} m, a floor contact of any body but the feet "
                f"({', '.join(self.feet)}: the leaf bodies within {FOOT_BAND_M:g} m of the lowest body origin in qpos0), "
                "or a diverged simulation")

    def __call__(self, data: mujoco.MjData) -> str | None:
        """Why this state is a fall (None: it is not)."""
        if not np.isfinite(data.qpos).all() or any(data.warning[w].number for w in _BAD_WARNINGS):
            return "diverged"
        if data.xpos[self.root, 2] < self.height:
            return "root below the fall height"
        geoms = data.contact.geom[:data.ncon]
        for g1, g2 in geoms:
            other = g2 if g1 == self.floor else g1 if g2 == self.floor else -1
            if other >= 0 and self.model.geom_bodyid[other] not in self.foot_ids:
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
    """Replay an exported policy on a fresh model of the robot (module docstring); the report, also
    written to `json_out` (atomically) when given."""
    if not seconds > 0:
        raise ValueError(f"seconds must be positive, got {seconds}")
    policy = load_policy(policy_path)
    meta = policy.meta
    model = build_model(meta, robot_xml, physics_hz, contacts)
    replay = Replay(policy, model, robot_xml)
    height = FALL_HEIGHT_FRACTION * replay.initial_qpos[2] if fall_height is None else fall_height
    floor = floor_name(model)
    fall = FallRule(model, floor, replay.observer.root, height, feet)
    steps = min(max(1, int(round(seconds * replay.control_hz))), replay.observer.last_row)
    report = {"policy": str(policy.path), "robot_xml": str(robot_xml), "character": meta.get("character"), "motion": meta.get("motion"),
              "physics_hz": replay.physics_hz, "trained_physics_hz": float(meta["physics_hz"]), "control_hz": replay.control_hz,
              "contacts": contacts, "seconds_requested": float(seconds), "seconds_limit": steps / replay.control_hz,
              "fall_rule": fall.describe(), "episodes": [run_episode(replay, fall, steps)]}
    if json_out is not None:
        write_json_atomic(json_out, report)
    return report


def floor_name(model: mujoco.MjModel) -> str:
    """The built model's ground plane (the XML's or the one `build_model` added)."""
    for g in range(model.ngeom):
        if model.geom_bodyid[g] == 0 and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE:
            return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g)
    raise Sim2SimError("internal: the built model has no floor")


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
