"""What a robot runtime needs beside the policy's ONNX graph, as the file's metadata (issue 25, item 5).

`sfv export --onnx` writes these string properties (each a JSON value) next to `action_std`, read
from the run's env as built (the compiled model, the action map, the reference track), so they
are the numbers the policy was trained against, not a second copy of them. `r` below is the
reference row of the current state: 0 at the reference's first frame, one more per control step.

| key | what |
|---|---|
| `sfv_runtime` | this table's version ("sfv-runtime-1") |
| `character`, `motion`, `mode` | the body, the reference it imitates, the env mode (`sfv`; `movingcam` rewrites observation slots) |
| `actuator_names`, `joint_order` | the actuators in action order and the joint each drives (MuJoCo names) |
| `actuator_gear` | each actuator's MuJoCo gear (6 numbers; a ball joint's three actuators: its x, y, z axes) |
| `default_joint_pos` | PD targets of a standing pose (`Character.default_joint_pos`), per actuator |
| `kp`, `kd`, `effort_limit`, `armature` | each actuator's PD gains (N m/rad, N m s/rad), torque limit (N m), the joint's rotor inertia |
| `target_limits` | [lower, upper] lists: every PD target is clipped to these |
| `action` | how an action becomes PD targets (`residual_wrench`: the last six outputs of a policy trained with a residual root wrench, else null): `target = offset + scale * clip(action, -1, 1)`, then clipped; the step from row r acts towards row r + 1 and its `offset` is the reference's targets at row min(r + 1 + lead_steps, last row) for residual actions (`reference_track.targets`), zeros otherwise |
| `reference_targets`, `reference_loop` | the reference's PD targets at every control step of one pass of the clip (rows), and whether it repeats |
| `reference_track` | every row an episode from the first frame reads (`what` says how): the reference's `qpos`, `phase` and PD `targets` per control step, past one pass for a looped clip (its root moving on) |
| `initial_qpos`, `initial_qvel` | the reference's first frame (row 0), full precision, in the MJCF's qpos / qvel order |
| `control_hz`, `physics_hz` | the policy's rate and the simulation's it was trained at |
| `physics` | the trained model's integrator, joint damping and floor contacts (the geoms paired with the floor, the pairs' friction and condim; self-collision off) |
| `ground_contacts` | `allowed_bodies`: the MuJoCo bodies that may touch the floor without a fall in this clip (the env's contact rule, `actors/envs/falls.py`: the feet, and the hands of a cartwheel, the whole body of a get-up); a floor contact of any other body ends the episode |
| `observation_layout` | the observation's blocks (name, start, size, what: exact definitions), `observation_links` the MuJoCo bodies of its link blocks in order (the root first) |
| `observation_reference` | the reference rows observed ahead (`root_steps`, `pose_steps`) and whether the reference root is re-synchronised to the character's at each new cycle (`root_sync`) |
"""
from __future__ import annotations

import json

import mujoco
import numpy as np

RUNTIME_FORMAT = "sfv-runtime-1"

_HEADING = ("the heading frame: the world turned about z by the root body's yaw th = atan2(R[1,0], R[0,0]) "
            "(R: its world rotation matrix, MuJoCo xmat); a world vector v enters it as Rz(th)^T v")
_ROTATION = "conj(q_h) * q (Hamilton product) with q_h = (cos th/2, 0, 0, sin th/2); w x y z, the sign chosen so that w >= 0"
# Exact definitions of the blocks (`actors/character/features.py` writes them, `services/export/sim2sim/` reproduces them).
_WHAT = {
    "root_height": "world z of the root body's origin (xpos of observation_links[0]), m; the floor is z = 0",
    "link_positions": f"per link of observation_links: its body origin (xpos) minus the root body's origin, in {_HEADING}; m, x y z per link",
    "link_rotations": f"per link: its body's world quaternion q (xquat) turned into the heading frame: {_ROTATION}",
    "link_linear_velocities": "per link: the world linear velocity of its body origin (mj_objectVelocity of the mjOBJ_XBODY, world-aligned; not the centre of mass) in the heading frame, m/s",
    "link_angular_velocities": "per link: its body's world angular velocity in the heading frame, rad/s",
    "reference_root_positions": ("per k of observation_reference.root_steps: reference_track.qpos[min(r + k, last row)][0:3], x and y plus the "
                                 "root-sync offset, minus the root body's origin, in the heading frame; m"),
    "reference_root_rotations": f"per k of observation_reference.root_steps: reference_track.qpos[min(r + k, last row)][3:7] as q in {_ROTATION}",
    "phase": "reference_track.phase[r], the clip's phase in [0, 1]",
    "reference_poses": ("per k of observation_reference.pose_steps: the reference pose reference_track.qpos[min(r + k, last row)] (forward "
                        "kinematics) seen as root_height and link_positions are, in its own heading frame: 1 + 3 x links numbers a step"),
}
_TRACK_WHAT = ("row r is the reference r control steps after its first frame (an index past the last row reads the last row); qpos: MuJoCo qpos (the root's free joint: x y z, w x y z; then the joints in MJCF order); phase in [0, 1]; "
               "targets: the PD targets of that pose, per actuator")
_SYNC_WHAT = ("offset (x, y) added to the reference roots observed: at the first frame the character's root xy minus "
              "reference_track.qpos[0][0:2] (zero from the first frame); with root_sync, reset the same way at every row r where "
              "reference_track.phase[r] < phase[r - 1] (a new cycle), held in between")


def _numbers(values) -> list:
    return [float(f"{v:.7g}") for v in np.ravel(values)]  # 7 significant digits: float32's, and the MJCF's 6 kept


def _name(model: mujoco.MjModel, kind: mujoco.mjtObj, index: int) -> str:
    return mujoco.mj_id2name(model, kind, int(index))


def _pd(model: mujoco.MjModel) -> dict:
    joints = model.actuator_trnid[:, 0]
    return {
        "actuator_names": [_name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a) for a in range(model.nu)],
        "joint_order": [_name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in joints],
        "actuator_gear": [_numbers(gear) for gear in model.actuator_gear],
        "kp": _numbers(model.actuator_gainprm[:, 0]),  # position actuators: force = kp (target - q) - kv qdot
        "kd": _numbers(-model.actuator_biasprm[:, 2]),
        "effort_limit": _numbers(model.actuator_forcerange[:, 1]),
        "armature": _numbers(model.dof_armature[model.jnt_dofadr[joints]]),
    }


def _action(env) -> dict:
    actions = env.actions
    residual = actions.residual
    wrench = env.core.residual
    return {"parameterisation": actions.parameterisation, "dim": int(actions.action_dim), "clip": [-1.0, 1.0],
            "scale": _numbers(actions.scale), "offset": "reference_targets" if residual else "zeros",
            "lead_steps": int(env.target_lead_steps) if residual else 0,
            "elementwise": actions.parameterisation == "exp_map",  # one action per actuator (a ball joint: its 3 exp-map targets)
            # a residual wrench on the root (actors/envs/residual_force.py): the policy's last six outputs, no actuator's
            "residual_wrench": None if wrench is None else {
                "dims": [int(actions.action_dim), int(actions.action_dim) + 6], "scale": _numbers(wrench.scale),
                "what": "force (N) then torque (N m) = scale * clip(action, -1, 1), in the root body's frame, at its centre of mass; "
                        "a simulation aid (not a motor): a robot runtime has no such actuator"}}


def _physics(env) -> dict:
    """Integrator, joint damping and the floor's contact pairs of the trained model."""
    model, floor = env.model, env.humanoid.floor_geom_id
    pairs = [p for p in range(model.npair) if floor in (model.pair_geom1[p], model.pair_geom2[p])]
    geoms = [int(model.pair_geom2[p] if model.pair_geom1[p] == floor else model.pair_geom1[p]) for p in pairs]
    first = pairs[0] if pairs else None
    return {"integrator": mujoco.mjtIntegrator(int(model.opt.integrator)).name.removeprefix("mjINT_").lower(),
            "joint_damping": float(env.config.physics.joint_damping),
            "self_collision": False,
            "floor_contacts": {"geoms": [_name(model, mujoco.mjtObj.mjOBJ_GEOM, g) for g in geoms],
                               "friction": _numbers(model.pair_friction[first]) if first is not None else [],
                               "condim": int(model.pair_dim[first]) if first is not None else 3}}


def _ground_contacts(env) -> dict:
    """The bodies whose floor contact the env's fall rule allows (its links less its fall links)."""
    falls = set(env.fall_detector.links.tolist())
    bodies = [b for i, b in enumerate(env.humanoid.body_ids) if i not in falls]
    return {"allowed_bodies": [_name(env.model, mujoco.mjtObj.mjOBJ_BODY, b) for b in bodies],
            "what": "bodies whose floor contact is not a fall in this clip; a floor contact of any other body ends the episode"}


def _observation_links(env) -> list[str]:
    """The bodies whose features fill the link blocks, in the order written (MuJoCo's bodies 1..n:
    `FeatureExtractor.capture`; the humanoid3d's link list orders them otherwise)."""
    n = env.humanoid.character.num_links
    return [_name(env.model, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(1, n + 1)]


def _layout(env, scene_dim: int) -> list[dict]:
    from actors.character.features import observation_layout

    config = env.config
    layout = observation_layout(env.humanoid.character, len(config.reference_obs_steps), len(config.reference_pose_obs_steps), scene_dim,
                                env.heightmap_dim)
    return [{**block, "what": _WHAT.get(block["name"], block["what"])} for block in layout]


def _reference_track(track) -> dict:
    return {"what": _TRACK_WHAT, "rows": int(track.rows), "qpos": [_numbers(row) for row in track.qpos],
            "phase": _numbers(track.phase), "targets": [_numbers(row) for row in track.ctrl]}


def runtime_metadata(env) -> dict[str, str]:
    """The metadata of the policy trained in `env` (an `ImitationEnv` built from the run's config)."""
    character, config, track = env.humanoid.character, env.config, env.track
    scene_dim = env.obs_dim - env.scene_obs_start - env.heightmap_dim
    values = {
        "sfv_runtime": RUNTIME_FORMAT,
        "character": character.name,
        "motion": env.motion.name,
        "mode": config.mode,
        **_pd(env.model),
        "default_joint_pos": _numbers(character.default_joint_pos),
        "target_limits": [_numbers(actions_limit) for actions_limit in (env.actions.lower, env.actions.upper)],
        "action": _action(env),
        "reference_targets": [_numbers(row) for row in track.ctrl[:track.start_steps]],
        "reference_loop": bool(env.motion.loop),
        "reference_track": _reference_track(track),
        "initial_qpos": [float(v) for v in track.qpos[0]],
        "initial_qvel": [float(v) for v in track.qvel[0]],
        "control_hz": float(config.control_hz),
        "physics_hz": float(config.physics.physics_hz),
        "physics": _physics(env),
        "ground_contacts": _ground_contacts(env),
        "observation_layout": _layout(env, scene_dim),
        "observation_links": _observation_links(env),
        "observation_reference": {"root_steps": [int(k) for k in env.reference_obs.steps],
                                  "pose_steps": [int(k) for k in env.reference_pose_obs.steps],
                                  "root_sync": bool(env.root_sync.enabled), "what": _SYNC_WHAT},
    }
    return {key: json.dumps(value) for key, value in values.items()}
