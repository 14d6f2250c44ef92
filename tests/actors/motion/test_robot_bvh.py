"""BVH of a robot's motion (`actors/motion/formats/robot_bvh.py`): the MJCF's bodies as the
hierarchy, read back by our own reader, and its forward kinematics against MuJoCo's.

The G1's tests need its cached model (`sfv models fetch --robot g1`) and skip without it; the
small MJCF below (rotated bodies, hinges off the body origin, two hinges in one body, a body
without a joint) needs nothing."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

from actors.character import g1_model
from actors.motion.formats.bvh import UNITS, read_bvh, yup_to_zup_vec
from actors.motion.formats.bvh_pose import bvh_forward_kinematics
from actors.motion.formats.robot_bvh import robot_bvh_text, robot_motion_qpos, robot_skeleton, write_robot_bvh
from learner.errors import SfvError

needs_g1 = pytest.mark.skipif(not g1_model.model_available(), reason="G1 model not cached (sfv models fetch --robot g1)")
MM = 1e-3
PRINTED = {"cm": 1e-6, "m": 1e-5}  # metres: what six printed decimals of the lengths (and of degrees) leave


def bvh_positions_m(path, units: str) -> np.ndarray:
    """(T, J, 3) global joint positions of the file by our reader's forward kinematics, MuJoCo's Z-up metres."""
    positions, _ = bvh_forward_kinematics(read_bvh(path))
    return yup_to_zup_vec(positions) / UNITS[units]


def mujoco_points(model: mujoco.MjModel, qpos: np.ndarray, body_ids: np.ndarray) -> np.ndarray:
    """(T, B, 3) where each body's BVH joint sits: its hinge anchor (xanchor), else its origin (xpos)."""
    data = mujoco.MjData(model)
    out = np.empty((len(qpos), len(body_ids), 3))
    for t, row in enumerate(qpos):
        data.qpos[:] = row
        mujoco.mj_kinematics(model, data)
        for k, body in enumerate(body_ids):
            hinge = model.body_jntadr[body] if model.body_jntnum[body] else -1
            is_hinge = hinge >= 0 and model.jnt_type[hinge] == mujoco.mjtJoint.mjJNT_HINGE
            out[t, k] = data.xanchor[hinge] if is_hinge else data.xpos[body]
    return out


# --------------------------------------------------------------- any MJCF robot
TOY = """
<mujoco>
  <worldbody>
    <body name="base" pos="0 0 1">
      <freejoint/>
      <geom type="box" size=".1 .1 .1" mass="1"/>
      <body name="arm" pos=".2 .05 .1" quat="0.9238795 0.3826834 0 0">
        <joint name="shoulder" type="hinge" axis="0 1 0" pos=".03 0 -.02"/>
        <geom type="capsule" fromto="0 0 0 .3 0 0" size=".03" mass="1"/>
        <body name="forearm" pos=".3 0 0" quat="0.8660254 0 0 0.5">
          <joint name="elbow_a" type="hinge" axis="0 0 1" pos=".01 .02 0"/>
          <joint name="elbow_b" type="hinge" axis="1 1 0" pos=".01 .02 0"/>
          <geom type="capsule" fromto="0 0 0 .25 0 0" size=".025" mass="1"/>
          <body name="hand" pos=".25 0 .01" quat="0.7071068 0 0.7071068 0">
            <geom type="sphere" size=".04" pos=".05 0 0" mass=".3"/>
          </body>
        </body>
      </body>
      <body name="leg" pos="0 -.05 -.15">
        <joint name="hip" type="hinge" axis="1 0 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 -.4" size=".04" mass="1"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def random_qpos(model: mujoco.MjModel, frames: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    qpos = rng.uniform(-3.0, 3.0, (frames, model.nq))
    quat = rng.normal(size=(frames, 4))
    qpos[:, 0:3] = rng.normal(size=(frames, 3))
    qpos[:, 3:7] = quat / np.linalg.norm(quat, axis=1, keepdims=True)
    return qpos


@pytest.mark.parametrize("units", ["cm", "m"])
def test_any_mjcf_robot_comes_back_at_its_hinge_anchors(tmp_path, units):
    model = mujoco.MjModel.from_xml_string(TOY)
    bodies = np.arange(1, model.nbody)
    qpos = random_qpos(model, 40)
    path = tmp_path / "toy.bvh"
    path.write_text(robot_bvh_text(robot_skeleton(model, bodies), qpos, 25.0, units))
    bvh = read_bvh(path)
    assert [j.name for j in bvh.joints] == ["base", "arm", "forearm", "hand", "leg"]
    assert [j.parent for j in bvh.joints] == [-1, 0, 1, 2, 0]
    assert [j.end_site is not None for j in bvh.joints] == [False, False, False, True, True]
    assert bvh.quirks == {} and bvh.frame_time == pytest.approx(1 / 25.0)
    error = np.abs(bvh_positions_m(path, units) - mujoco_points(model, qpos, bodies)).max()
    assert error < PRINTED[units], f"max FK error {error:.2e} m"


def test_an_arenas_props_are_left_out_and_other_joints_are_one_line():
    model = mujoco.MjModel.from_xml_string(TOY.replace("</worldbody>", '<body name="box" pos="2 0 0"><freejoint/>'
                                                       '<geom type="box" size=".1 .1 .1"/></body></worldbody>'))
    assert robot_skeleton(model, range(1, 6)).names == ("base", "arm", "forearm", "hand", "leg")
    with pytest.raises(SfvError, match=r"robot BVH: the bodies have 2 roots \(base, box\)"):
        robot_skeleton(model, range(1, model.nbody))
    ball = mujoco.MjModel.from_xml_string(TOY.replace('name="hip" type="hinge"', 'name="hip" type="ball"'))
    with pytest.raises(SfvError, match="robot BVH: body leg has a joint that is not a hinge"):
        robot_skeleton(ball, range(1, ball.nbody))
    fixed = mujoco.MjModel.from_xml_string(TOY.replace("<freejoint/>", ""))
    with pytest.raises(SfvError, match="robot BVH: the root body base needs one free joint"):
        robot_skeleton(fixed, range(1, fixed.nbody))
    apart = mujoco.MjModel.from_xml_string(TOY.replace('axis="1 1 0" pos=".01 .02 0"', 'axis="1 1 0" pos="0 0 0"'))
    with pytest.raises(SfvError, match="robot BVH: the hinges of body forearm turn about different points"):
        robot_skeleton(apart, range(1, apart.nbody))


# ------------------------------------------------------------------------ the G1
@pytest.fixture(scope="module")
def g1():
    if not g1_model.model_available():
        pytest.skip("G1 model not cached (sfv models fetch --robot g1)")
    from actors.character.g1 import G1Model

    return G1Model()


@pytest.fixture(scope="module")
def g1_walk(walk_clip, g1):
    from actors.motion.robot_retarget import retarget_to_g1

    return retarget_to_g1(walk_clip)[0]


@needs_g1
@pytest.mark.parametrize("units", ["cm", "m"])
def test_the_g1_walk_as_bvh_has_mujocos_body_positions(g1, g1_walk, tmp_path, units):
    path = write_robot_bvh(g1_walk, g1, tmp_path / "walk_g1.bvh", units)
    assert [p.name for p in tmp_path.iterdir()] == ["walk_g1.bvh"]  # atomic: no temp file left
    bvh = read_bvh(path)
    assert bvh.quirks == {} and len(bvh.frames) == g1_walk.num_frames
    assert bvh.frame_time == pytest.approx(1.0 / g1_walk.fps, abs=1e-9)
    skeleton, qpos = robot_motion_qpos(g1_walk, g1)
    positions = bvh_positions_m(path, units)
    expected = mujoco_points(g1.model, qpos, skeleton.body_ids)
    for frame in (0, 7, 19, len(qpos) - 1):  # several frames; every one below
        assert np.abs(positions[frame] - expected[frame]).max() < MM
    error = np.abs(positions - expected).max()
    assert error < PRINTED[units], f"max FK error {error:.2e} m"
    data = mujoco.MjData(g1.model)  # the G1's hinges sit at the body origins: the joints are MuJoCo's xpos
    data.qpos[:] = qpos[19]
    mujoco.mj_kinematics(g1.model, data)
    np.testing.assert_allclose(positions[19], data.xpos[np.sort(g1.body_ids)], atol=1e-6)


@needs_g1
def test_one_joint_per_g1_body_and_three_channels_each(g1, g1_walk, tmp_path):
    path = write_robot_bvh(g1_walk, g1, tmp_path / "walk_g1.bvh")
    text = path.read_text()
    bodies = g1.character.num_links  # 30: the pelvis and 29 links, one hinge each
    keywords = [line.split()[0] for line in text.split("MOTION")[0].splitlines()[1:]]
    assert text.startswith("HIERARCHY\nROOT pelvis\n") and keywords.count("ROOT") == 1
    assert keywords.count("JOINT") == bodies - 1
    bvh = read_bvh(path)
    assert {j.name for j in bvh.joints} == set(g1.character.link_names)
    assert bvh.joints[0].channels == ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
    assert all(j.channels == ("Zrotation", "Xrotation", "Yrotation") for j in bvh.joints[1:])
    assert sorted(j.name for j in bvh.joints if j.end_site is not None) == sorted(
        f"{side}_{part}" for side in ("left", "right") for part in ("ankle_roll_link", "wrist_yaw_link"))
    frame_lines = text.split("Frame Time: ")[1].splitlines()[1:]
    assert len(frame_lines) == g1_walk.num_frames
    assert {len(line.split()) for line in frame_lines} == {6 + 3 * (bodies - 1)}  # 93
    offsets = {j.name: j.offset for j in bvh.joints}  # cm, Y up: the left hip 10.27 cm down, 6.45 cm to the left (-z)
    np.testing.assert_allclose(offsets["left_hip_pitch_link"], 100 * yup_offset(g1, "left_hip_pitch_link"), atol=1e-6)


def yup_offset(g1, body: str) -> np.ndarray:
    from actors.motion.formats.bvh import zup_to_yup_vec

    return zup_to_yup_vec(g1.model.body(body).pos)


@needs_g1
def test_a_motion_of_another_robot_is_one_line(g1, g1_walk, tmp_path):
    import dataclasses

    other = dataclasses.replace(g1_walk, character="h1")
    with pytest.raises(SfvError, match="a motion of the h1's 29 joints, not of the g1's"):
        write_robot_bvh(other, g1, tmp_path / "x.bvh")
    assert list(tmp_path.iterdir()) == []
