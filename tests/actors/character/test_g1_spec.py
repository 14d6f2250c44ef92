"""The G1's numbers (no model files needed): motors, gains, limits, mirror map, the Character shape."""
import numpy as np
import pytest

from actors.character import g1_spec as spec
from actors.character.g1 import G1_ROBOT


def _j(name: str) -> int:
    return spec.JOINT_NAMES.index(name)


def test_armature_and_gains_follow_from_the_motor_data():
    # 5020: 0.139e-4 * (46/18 + 1)^2 (56/16 + 1)^2 + 0.017e-4 * 4.5^2 + 0.169e-4 (kg m^2), by hand.
    armature_5020 = 0.139e-4 * (64 / 18 * 4.5) ** 2 + 0.017e-4 * 4.5 ** 2 + 0.169e-4
    assert spec.ARMATURE[_j("left_elbow_joint")] == pytest.approx(armature_5020, rel=1e-9)
    assert spec.KP[_j("left_elbow_joint")] == pytest.approx(armature_5020 * (20 * np.pi) ** 2, rel=1e-9)
    assert spec.KP[_j("left_elbow_joint")] == pytest.approx(14.25, abs=0.01)
    assert spec.KD[_j("left_elbow_joint")] == pytest.approx(4 * armature_5020 * 20 * np.pi, rel=1e-9)
    # The linkage joints: two 5020s, i.e. twice the armature, gains and effort.
    for joint in ("left_ankle_pitch_joint", "right_ankle_roll_joint", "waist_pitch_joint", "waist_roll_joint"):
        assert spec.ARMATURE[_j(joint)] == pytest.approx(2 * armature_5020)
        assert spec.EFFORT_LIMITS[_j(joint)] == 50.0
    assert spec.EFFORT_LIMITS[_j("left_knee_joint")] == 139.0 and spec.EFFORT_LIMITS[_j("waist_yaw_joint")] == 88.0
    assert spec.EFFORT_LIMITS[_j("right_wrist_yaw_joint")] == 5.0
    assert spec.KP[_j("right_knee_joint")] == pytest.approx(99.1, abs=0.05)


def test_joints_limits_and_layout():
    assert len(spec.JOINT_NAMES) == 29 and len(set(spec.JOINT_NAMES)) == 29
    assert np.all(spec.JOINT_LIMITS[:, 0] < 0) and np.all(spec.JOINT_LIMITS[:, 1] > 0)
    assert (spec.NQ, spec.NV) == (36, 35)
    assert spec.LINK_NAMES[0] == "pelvis" and len(spec.LINK_NAMES) == 30
    standing = spec.standing_joint_angles()
    assert standing[_j("left_knee_joint")] == 0.669 and standing[_j("right_elbow_joint")] == 0.6
    assert standing[_j("right_shoulder_roll_joint")] == -0.2 and standing[_j("waist_yaw_joint")] == 0.0
    assert np.all(standing >= spec.JOINT_LIMITS[:, 0]) and np.all(standing <= spec.JOINT_LIMITS[:, 1])


def test_mirror_map_pairs_left_with_right_and_flips_roll_and_yaw():
    assert np.array_equal(spec.JOINT_MIRROR[spec.JOINT_MIRROR], np.arange(29))
    assert np.array_equal(spec.LINK_MIRROR[spec.LINK_MIRROR], np.arange(30))
    assert spec.JOINT_NAMES[spec.JOINT_MIRROR[_j("left_hip_roll_joint")]] == "right_hip_roll_joint"
    assert spec.JOINT_MIRROR[_j("waist_yaw_joint")] == _j("waist_yaw_joint")
    sign = dict(zip(spec.JOINT_NAMES, spec.JOINT_MIRROR_SIGN))
    assert sign["left_hip_pitch_joint"] == 1 and sign["left_hip_roll_joint"] == -1 and sign["waist_yaw_joint"] == -1
    # Mirrored limits: the partner's range reflected by the sign (the XML's left/right ranges agree).
    for j in range(29):
        partner = spec.JOINT_LIMITS[spec.JOINT_MIRROR[j]]
        mirrored = np.sort(partner * spec.JOINT_MIRROR_SIGN[j])
        assert np.allclose(mirrored, spec.JOINT_LIMITS[j]), spec.JOINT_NAMES[j]


def test_the_g1_has_every_member_of_the_character_interface():
    from actors.character.base import Character

    members = [name for name in Character.__annotations__] + ["mjcf", "build"]
    assert all(hasattr(G1_ROBOT, name) for name in members)
    assert G1_ROBOT.kp.shape == G1_ROBOT.kd.shape == G1_ROBOT.torque_limits.shape == (G1_ROBOT.nu,)
    assert [spec.LINK_NAMES[i] for i in G1_ROBOT.end_effector_links] == list(spec.FEET + spec.HANDS)
    assert set(G1_ROBOT.reward_joint_weights) == set(spec.LINK_NAMES)


def test_the_hinge_axes_are_the_models():
    """The axes the state layout turns hinges about are g1.xml's (needs the fetched model)."""
    import re

    from actors.character.g1_model import default_model_dir

    path = default_model_dir() / "g1.xml"
    if not path.is_file():
        pytest.skip(f"no G1 model cached at {path} (sfv models fetch --robot g1)")
    xml = path.read_text()
    axes = {m.group(1): np.array(m.group(2).split(), float) for m in re.finditer(r'<joint[^>]*name="([^"]+)"[^>]*axis="([^"]+)"', xml)}
    np.testing.assert_array_equal(np.array([axes[n] for n in spec.JOINT_NAMES]), spec.HINGE_AXES)
