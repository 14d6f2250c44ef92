"""A sim-to-sim check of an exported policy: the robot runtime's view (issue 25, item 5).

A robot runtime has the ONNX file (`sfv export RUN --onnx`) and the robot's own MJCF, nothing of
the training code; this package is such a runtime in MuJoCo. It imports onnxruntime, mujoco and
numpy only (nothing of `learner`, `actors` or `services.training`: a test checks `sys.modules`
and every file's imports), and reproduces from the file's metadata
(`services/export/runtime_metadata.py`) what the env did:

- the model (`build_model`, `model.py`): the raw XML's bodies, joints and geoms; its own actuators
  removed and one MuJoCo position actuator per entry of `joint_order` (`actuator_names`,
  `actuator_gear`, `kp`, `kd`, `effort_limit`; the joint's `armature` and `physics.joint_damping`),
  a floor plane where the XML has none, `physics.integrator` and the timestep 1 / physics_hz (by
  default 1 kHz, not the rate it trained at, `physics_hz`); contacts as trained
  (`physics.floor_contacts`: explicit floor pairs with their friction and condim, self-collision
  off) or, with `contacts="xml"`, as the XML declares them;
- the observation (`Observer`, `observer.py`), each block of `observation_layout` computed from
  MuJoCo data as its `what` defines it, for the bodies `observation_links`, with the reference rows
  ahead of `observation_reference` read from `reference_track` (root-synchronised per cycle as it
  says);
- the control (`Replay`, `replay.py`): from the reference's first frame (`initial_qpos`,
  `initial_qvel`), every control step (`control_hz`) the observation through the ONNX graph,
  `target = offset + scale * clip(action, -1, 1)` (`action`; offset
  `reference_track.targets[min(r + 1 + lead_steps, last)]` for residual actions), clipped to
  `target_limits` and held while physics steps at its own rate (a control period that is not a
  whole number of physics steps ends at the nearest one).

The report (`run_sim2sim`, `replay.py`) holds one episode from the first frame: the seconds it
survived under the fall rule it names (`FallRule`: the root's origin below a height, by default
half its first-frame height, or a floor contact of any body but those the clip allows: the file's
`ground_contacts` (the env's contact rule: the feet, a cartwheel's hands too), or for a file written
before it the feet, the leaf bodies of the kinematic tree within 10 cm of the lowest body origin in
the model's reference configuration qpos0; or a diverged simulation), the mean |target - joint position| over physics steps and actuators, and
the largest fraction of physics steps any actuator spent at its effort limit; written as JSON
atomically (`write_json_atomic`).

Metadata keys read (`REQUIRED_KEYS`, `policy.py`, which opens the file (`load_policy`) and checks
what this runtime can replay; a file without one is refused, naming it): sfv_runtime, joint_order,
actuator_names, actuator_gear, kp, kd, effort_limit, armature, target_limits, action,
reference_track, initial_qpos, initial_qvel, control_hz, physics_hz (reported), physics,
observation_layout, observation_links, observation_reference; and, where present, character,
motion (reported), mode (only `sfv` is replayed) and ground_contacts (the fall rule).

Files: `policy.py` the ONNX file and its metadata checks (`Sim2SimError`, `Policy`, `load_policy`);
`model.py` the fresh MuJoCo model (`build_model`, `floor_name`); `observer.py` the observation
(`Observer`, `update_kinematics`); `replay.py` the control loop, fall rule and report (`Replay`,
`EpisodeStats`, `FallRule`, `lowest_leaves`, `run_episode`, `run_sim2sim`, `write_json_atomic`).
"""
from __future__ import annotations

from services.export.sim2sim.model import CONTACT_MODES, DEFAULT_PHYSICS_HZ, FLOOR_NAME, build_model, floor_name
from services.export.sim2sim.observer import Observer, update_kinematics
from services.export.sim2sim.policy import OBSERVED_BLOCKS, OPTIONAL_KEYS, REQUIRED_KEYS, Policy, Sim2SimError, load_policy
from services.export.sim2sim.replay import (
    FALL_HEIGHT_FRACTION,
    FOOT_BAND_M,
    SATURATED,
    EpisodeStats,
    FallRule,
    Replay,
    lowest_leaves,
    run_episode,
    run_sim2sim,
    write_json_atomic,
)

__all__ = ["CONTACT_MODES", "DEFAULT_PHYSICS_HZ", "FALL_HEIGHT_FRACTION", "FLOOR_NAME", "FOOT_BAND_M", "OBSERVED_BLOCKS",
           "OPTIONAL_KEYS", "REQUIRED_KEYS", "SATURATED", "EpisodeStats", "FallRule", "Observer", "Policy", "Replay",
           "Sim2SimError", "build_model", "floor_name", "load_policy", "lowest_leaves", "run_episode", "run_sim2sim",
           "update_kinematics", "write_json_atomic"]
