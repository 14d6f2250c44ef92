"""What a robot runtime needs beside the policy's ONNX graph, as the file's metadata (issue 25, item 5).

`sfv export --onnx` writes these string properties (each a JSON value) next to `action_std`, read
from the run's env as built (the compiled model, the action map, the reference track), so they
are the numbers the policy was trained against, not a second copy of them:

| key | what |
|---|---|
| `sfv_runtime` | this table's version ("sfv-runtime-1") |
| `character`, `motion` | the body and the reference it imitates |
| `actuator_names`, `joint_order` | the actuators in action order and the joint each drives (MuJoCo names) |
| `default_joint_pos` | PD targets of a standing pose (`Character.default_joint_pos`), per actuator |
| `kp`, `kd`, `effort_limit`, `armature` | each actuator's PD gains (N m/rad, N m s/rad), torque limit (N m), the joint's rotor inertia |
| `target_limits` | [lower, upper] lists: every PD target is clipped to these |
| `action` | how an action becomes PD targets: `target = offset + scale * clip(action, -1, 1)`, then clipped; `offset` is `reference_targets[row + lead_steps]` for residual actions, zeros otherwise |
| `reference_targets`, `reference_loop` | the reference's PD targets at every control step of one pass of the clip (rows), and whether it repeats |
| `control_hz`, `physics_hz` | the policy's rate and the simulation's it was trained at |
| `observation_layout` | the observation's blocks (name, start, size, what: `actors/character/features.py`), `observation_links` their link order |
"""
from __future__ import annotations

import json

import mujoco
import numpy as np

RUNTIME_FORMAT = "sfv-runtime-1"


def _numbers(values) -> list:
    return [float(f"{v:.7g}") for v in np.ravel(values)]  # 7 significant digits: float32's, and the MJCF's 6 kept


def _pd(model: mujoco.MjModel) -> dict:
    joints = model.actuator_trnid[:, 0]
    return {
        "actuator_names": [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a) for a in range(model.nu)],
        "joint_order": [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, int(j)) for j in joints],
        "kp": _numbers(model.actuator_gainprm[:, 0]),  # position actuators: force = kp (target - q) - kv qdot
        "kd": _numbers(-model.actuator_biasprm[:, 2]),
        "effort_limit": _numbers(model.actuator_forcerange[:, 1]),
        "armature": _numbers(model.dof_armature[model.jnt_dofadr[joints]]),
    }


def _action(env) -> dict:
    actions = env.actions
    residual = actions.residual
    return {"parameterisation": actions.parameterisation, "dim": int(actions.action_dim), "clip": [-1.0, 1.0],
            "scale": _numbers(actions.scale), "offset": "reference_targets" if residual else "zeros",
            "lead_steps": int(env.target_lead_steps) if residual else 0,
            "elementwise": actions.parameterisation == "exp_map" and actions.num_spherical == 0}


def runtime_metadata(env) -> dict[str, str]:
    """The metadata of the policy trained in `env` (an `ImitationEnv` built from the run's config)."""
    from actors.character.features import observation_layout

    character, config, track = env.humanoid.character, env.config, env.track
    scene_dim = env.obs_dim - env.scene_obs_start
    values = {
        "sfv_runtime": RUNTIME_FORMAT,
        "character": character.name,
        "motion": env.motion.name,
        **_pd(env.model),
        "default_joint_pos": _numbers(character.default_joint_pos),
        "target_limits": [_numbers(actions_limit) for actions_limit in (env.actions.lower, env.actions.upper)],
        "action": _action(env),
        "reference_targets": [_numbers(row) for row in track.ctrl[:track.start_steps]],
        "reference_loop": bool(env.motion.loop),
        "control_hz": float(config.control_hz),
        "physics_hz": float(config.physics.physics_hz),
        "observation_layout": observation_layout(character, len(config.reference_obs_steps), len(config.reference_pose_obs_steps), scene_dim),
        "observation_links": list(character.link_names),
    }
    return {key: json.dumps(value) for key, value in values.items()}
