"""The humanoid's MJCF, generated from `skeleton.py` (compiled by `humanoid3d.Humanoid`).

PD control runs inside MuJoCo: every joint axis gets a built-in `position` actuator with the
character's kp, kd (`kv`, integrated implicitly by `implicitfast`) and torque limit. A
spherical joint is a MuJoCo ball joint with three position actuators whose gears are the
joint's x, y, z axes: MuJoCo measures a ball joint's actuator length as the gear's component
of the joint's rotation vector, so the three targets are the joint's exponential
coordinates. Self-collision is off (as in DeepMimic); every link collides with the ground,
which is the arena's (`actors/arenas/flat.py`), composed in by `build_mjcf`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from actors.arenas.flat import FlatFloor
from actors.character.skeleton import (
    HINGE_AXIS,
    JOINT_LINKS,
    LINKS,
    NUM_LINKS,
    joint_limits_zup,
    yup_to_zup,
)

STANDING_ROOT_HEIGHT = 0.8814  # hip + knee + ankle offsets + foot half height


@dataclass(frozen=True)
class PhysicsConfig:
    physics_hz: float = field(default=300.0, metadata={"help": "physics (MuJoCo step) rate in Hz; 300 is the lowest at which a held pose and a walk playback stay stable (docs/training.md); the paper used 1200 in Bullet"})
    friction: float = field(default=0.9, metadata={"help": "sliding friction between the character and the ground"})
    armature: float = field(default=0.01, metadata={"help": "rotor inertia added to every actuated joint (kg m^2); keeps low physics rates stable"})
    joint_damping: float = field(default=0.0, metadata={"help": "passive joint damping on top of the PD kd"})


def control_substeps(physics: PhysicsConfig, control_hz: float) -> int:
    """Physics steps per control step: a whole number, or the rate pair is refused (ValueError)."""
    n = physics.physics_hz / control_hz
    if abs(n - round(n)) > 1e-9 or n < 1:
        raise ValueError(f"physics_hz ({physics.physics_hz}) must be a whole multiple of control_hz ({control_hz})")
    return int(round(n))


def _fmt(v) -> str:
    return " ".join(f"{x:.6g}" for x in np.ravel(v))


def _geom_xml(link) -> str:
    centre = yup_to_zup(link.geom_offset_yup)
    common = f'name="{link.name}_geom" mass="{link.mass}"'
    if link.shape == "sphere":
        return f'<geom {common} type="sphere" size="{link.size[0]}" pos="{_fmt(centre)}"/>'
    if link.shape == "capsule":
        radius, length = link.size
        half = np.array([0.0, 0.0, length / 2.0])  # DeepMimic capsules run along the link's Y-up y = Z-up z
        return f'<geom {common} type="capsule" size="{radius}" fromto="{_fmt(centre - half)} {_fmt(centre + half)}"/>'
    ex, ey, ez = link.size
    return f'<geom {common} type="box" size="{_fmt(np.array([ex, ez, ey]) / 2.0)}" pos="{_fmt(centre)}"/>'


def _joint_xml(link, config: PhysicsConfig) -> str:
    extra = f'armature="{config.armature}" damping="{config.joint_damping}"'
    if link.joint == "spherical":
        cone = float(np.max(np.abs(joint_limits_zup(link))))
        return f'<joint name="{link.name}" type="ball" range="0 {cone:.4g}" {extra}/>'
    if link.joint == "revolute":
        lo, hi = joint_limits_zup(link)[0]
        return f'<joint name="{link.name}" type="hinge" axis="{_fmt(HINGE_AXIS)}" range="{lo} {hi}" {extra}/>'
    return ""


def _body_xml(index: int, config: PhysicsConfig, indent: str) -> str:
    link = LINKS[index]
    if index == 0:
        pos = np.array([0.0, 0.0, STANDING_ROOT_HEIGHT])
        joint = '<freejoint name="root"/>'
        camera = '<camera name="track" mode="trackcom" pos="0 -3.5 0.4" xyaxes="1 0 0 0 0.2 1"/>'
    else:
        pos = yup_to_zup(link.offset_yup)
        joint = _joint_xml(link, config)
        camera = ""
    children = "".join(_body_xml(c, config, indent + "  ") for c in range(NUM_LINKS) if LINKS[c].parent == index)
    return (
        f'{indent}<body name="{link.name}" pos="{_fmt(pos)}">\n'
        f"{indent}  {joint}{camera}{_geom_xml(link)}\n{children}{indent}</body>\n"
    )


def _actuators_xml() -> str:
    """Actuators of all spherical joints first (x, y, z each), then the revolute joints, so
    that the controls split into contiguous (8, 3) and (4,) blocks without gathering."""
    lines = []
    order = [i for i in JOINT_LINKS if LINKS[i].joint == "spherical"] + [i for i in JOINT_LINKS if LINKS[i].joint == "revolute"]
    for index in order:
        link = LINKS[index]
        gains = f'kp="{link.kp}" kv="{link.kd}" forcerange="{-link.torque_limit} {link.torque_limit}"'
        if link.joint == "spherical":
            for axis, gear in zip("xyz", ("1 0 0", "0 1 0", "0 0 1")):
                lines.append(f'<position name="{link.name}_{axis}" joint="{link.name}" gear="{gear} 0 0 0" {gains}/>')
        else:
            lines.append(f'<position name="{link.name}" joint="{link.name}" {gains}/>')
    return "\n    ".join(lines)


def _props_xml(arena) -> str:
    """Bodies an arena adds after the walker (a movable box): after it, so the walker keeps
    qpos[:35], qvel[:34] and bodies 1..15 whatever the scene holds."""
    props = getattr(arena, "props_xml", None)
    return props() if props is not None else ""


def build_mjcf(config: PhysicsConfig = PhysicsConfig(), arena=None) -> str:
    """MJCF text of the humanoid in an arena (`actors/arenas/flat.py`; a flat floor by default). The
    arena brings its assets, world geoms and its contact pairs with the humanoid's geoms."""
    arena = FlatFloor() if arena is None else arena
    walker_geoms = [(link.name, f"{link.name}_geom") for link in LINKS]
    return f"""<mujoco model="sfv_humanoid3d">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{1.0 / config.physics_hz:.8g}" integrator="implicitfast"/>
  <visual><global offwidth="1280" offheight="720"/><quality shadowsize="2048"/></visual>
  <default>
    <geom contype="0" conaffinity="0" condim="3" friction="{config.friction} 0.005 0.0001" rgba="0.75 0.6 0.45 1"/>
  </default>
  <asset>
    {arena.assets_xml()}
  </asset>
  <worldbody>
    {arena.worldbody_xml()}
{_body_xml(0, config, "    ")}{_props_xml(arena)}  </worldbody>
  <contact>
    {arena.contact_pairs_xml(walker_geoms, config.friction)}
  </contact>
  <actuator>
    {_actuators_xml()}
  </actuator>
</mujoco>
"""
