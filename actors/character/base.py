"""The Character interface: the simulated body an env puts in an arena.

A character describes itself (links, joints, their PD gains and torque limits, end effectors,
the links always allowed on the ground, its left/right mirror map and hinge mirror signs, the
imitation reward's per-joint weights, and the sizes of its own coordinates: qpos, qvel,
actuators) and builds its
MuJoCo model in an arena (`build(physics, arena)`: the compiled character with its bodies'
ids and each joint's qpos / DoF addresses, `joint_qpos_adr`, `joint_dof_adr`). An arena's
props come after the character's own coordinates, so `qpos[:nq]`, `qvel[:nv]` and `ctrl[:nu]`
are the character's whatever the arena holds. The modules that turn a body into numbers
(features, actions, mirror maps, state layout, the reward's weights, the fall rule) read it
from the character they are given (the built model's `character`, a `CompiledCharacter`:
`compiled.py`), never from a skeleton. `humanoid3d` (DeepMimic's humanoid,
`actors/character/humanoid3d.py`) is the first, the Unitree G1 (`g1.py`) the second; the
registry of characters by name is `characters.py`.
"""
from __future__ import annotations

from typing import Protocol

import numpy as np


class Character(Protocol):
    name: str
    link_names: tuple[str, ...]
    num_links: int  # MuJoCo bodies 1..num_links are the links (an arena's bodies come after them)
    joint_names: tuple[str, ...]  # the actuated joints, in motion-file order
    joint_is_spherical: np.ndarray  # (joints,) bool: 3-DoF ball or 1-DoF hinge
    joint_links: np.ndarray  # (joints,) the link each joint moves (the reward's weights are by link)
    nq: int  # the character's own qpos size (a free root first)
    nv: int  # its qvel size
    nu: int  # its actuators: the PD targets an action sets
    hinge_axes: np.ndarray  # (hinge joints, 3) the axis each 1-DoF joint turns about, in its parent's frame
    actuator_limits: np.ndarray  # (nu, 2) target limits: ball joints' 3 axes first, then the hinges
    default_joint_pos: np.ndarray  # (nu,) the PD targets of a standing pose (what a robot runtime holds before a policy acts)
    kp: np.ndarray  # (joints,) PD gains
    kd: np.ndarray
    torque_limits: np.ndarray  # (joints,) N m
    # (nu,) each actuator's residual action range in units of the env's residual_action_scale
    # (humanoid3d: 1; a body with soft motors needs more radians for the same share of its torque)
    residual_scale_factors: np.ndarray
    end_effector_links: np.ndarray  # link indices (the reward's end effectors)
    feet: tuple[str, ...]  # links always allowed on the ground (every clip's fall rule allows them)
    torso_links: np.ndarray  # link indices of the torso and head (a task's fall rule)
    fall_contact_geoms: tuple[str, ...]  # the torso's and head's geoms (the compiled model's `fall_geom_ids`)
    link_mirror: np.ndarray  # link -> its left/right partner
    joint_mirror: np.ndarray  # joint -> its partner
    # (joints,) +1 / -1: a mirrored hinge angle is sign x its partner's (ball joints +1, mirrored as
    # quaternions); checked against the model's hinge axes by `symmetry.derive_hinge_mirror_signs`
    joint_mirror_sign: np.ndarray
    reward_joint_weights: dict[str, float]  # the imitation reward's per-joint weights, by link name

    def mjcf(self, physics, arena=None) -> str:
        """MJCF text of the character in `arena`."""
        ...

    def build(self, physics, arena=None):
        """The compiled character in `arena` (model, body ids, joint qpos / DoF addresses)."""
        ...
