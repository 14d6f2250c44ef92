"""The exported file: its ONNX session and the runtime metadata sim2sim can replay (package docstring)."""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

REQUIRED_KEYS = ("sfv_runtime", "joint_order", "actuator_names", "actuator_gear", "kp", "kd", "effort_limit", "armature",
                 "target_limits", "action", "reference_track", "initial_qpos", "initial_qvel", "control_hz", "physics_hz",
                 "physics", "observation_layout", "observation_links", "observation_reference")
OPTIONAL_KEYS = ("character", "motion", "mode", "ground_contacts")
OBSERVED_BLOCKS = ("root_height", "link_positions", "link_rotations", "link_linear_velocities", "link_angular_velocities",
                   "reference_root_positions", "reference_root_rotations", "phase", "reference_poses")


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
    allowed = meta.get("ground_contacts", {"allowed_bodies": []})
    if not (isinstance(allowed, dict) and isinstance(allowed.get("allowed_bodies"), list)
            and all(isinstance(name, str) for name in allowed["allowed_bodies"])):
        raise Sim2SimError(f"{path}: metadata ground_contacts is not {{\"allowed_bodies\": [body names]}}")
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
