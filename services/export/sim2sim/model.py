"""The fresh MuJoCo model: the robot's raw MJCF with the metadata's actuators, floor, contacts and physics (package docstring)."""
from __future__ import annotations

import os
from pathlib import Path

import mujoco

from services.export.sim2sim.policy import Sim2SimError, _reason

DEFAULT_PHYSICS_HZ = 1000.0
CONTACT_MODES = ("training", "xml")
FLOOR_NAME = "sim2sim_floor"


# ---------------------------------------------------------------------------- the model
def build_model(meta: dict, robot_xml: str | os.PathLike, physics_hz: float = DEFAULT_PHYSICS_HZ,
                contacts: str = "training") -> mujoco.MjModel:
    """A fresh model of the robot from its raw MJCF with the metadata's actuators (package docstring)."""
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


def floor_name(model: mujoco.MjModel) -> str:
    """The built model's ground plane (the XML's or the one `build_model` added)."""
    for g in range(model.ngeom):
        if model.geom_bodyid[g] == 0 and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE:
            return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g)
    raise Sim2SimError("internal: the built model has no floor")
