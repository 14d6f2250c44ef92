"""Retargeting foreign BVH rigs onto the humanoid: the humanoid's own walk written through a
different skeleton (tests/foreign_rig.py) must come back as the walk.

Stated accuracy: joint and root rotations within 1e-3 rad, link positions within 1 cm. The
1 cm is the ground fit's doing: DeepMimic's walk sinks its soles 5.3 mm into the floor, and
the retargeter lifts the clip so that they touch it instead.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from actors.character import quaternion as qn
from actors.motion.formats.bvh import motion_to_bvh_text, write_bvh
from actors.motion.formats.bvh_import import import_bvh
from actors.character.foot_contact import sole_heights
from actors.character.kinematics import forward_kinematics
from actors.motion.reference_motion import ReferenceMotion
from actors.motion.formats.io import load_motion
from actors.motion.formats.retarget import RetargetOptions
from actors.character.skeleton import HINGE_AXIS, JOINT_NAMES
from services.cli import main
from tests.foreign_rig import (
    CGSPEED_CMU_NAMES,
    MIXAMO_NAMES,
    UNREAL_MAP,
    UNREAL_NAMES,
    foreign_bvh_text,
)

ANGLE_TOL_RAD = 1e-3
POSITION_TOL_M = 0.01


def rotation_error(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return qn.quat_angle(qn.quat_mul(qn.quat_conj(a), b))


def assert_same_motion(original: ReferenceMotion, back: ReferenceMotion) -> None:
    assert back.num_frames == original.num_frames
    assert rotation_error(original.joint_rot, back.joint_rot).max() < ANGLE_TOL_RAD
    assert rotation_error(original.root_rot, back.root_rot).max() < ANGLE_TOL_RAD
    pos_a, _ = forward_kinematics(original.root_pos, original.root_rot, original.joint_rot)
    pos_b, _ = forward_kinematics(back.root_pos, back.root_rot, back.joint_rot)
    assert np.abs(pos_a - pos_b).max() < POSITION_TOL_M  # every link, end effectors included


@pytest.mark.parametrize("frame, expect_up, expect_forward", [("z_up", "+z", "-y"), ("y_up", "+y", "+z")])
def test_mixamo_rig_in_a_pose_retargets_back(walk_clip, tmp_path, frame, expect_up, expect_forward):
    path = tmp_path / "walk.bvh"
    path.write_text(foreign_bvh_text(walk_clip, MIXAMO_NAMES, frame))
    back, report = import_bvh(path)
    assert (report["rig"], report["up"], report["forward"], report["units"]) == ("mixamo", expect_up, expect_forward, "cm")
    assert report["leg_ratio"] == pytest.approx(1 / 1.1, rel=1e-4)
    assert report["folded_joints"] == 9  # spine, 2 collars, 6 finger joints (head, hands, toes are tips)
    assert report["clipped_max_deg"] == 0.0 and back.loop
    assert_same_motion(walk_clip, back)


@pytest.mark.parametrize("arm_out_deg", [0.0, 90.0])
def test_t_pose_and_arms_down_rest_poses(walk_clip, tmp_path, arm_out_deg):
    path = tmp_path / "walk.bvh"
    path.write_text(foreign_bvh_text(walk_clip, MIXAMO_NAMES, "y_up", body_scale=0.9, arm_out_deg=arm_out_deg))
    assert_same_motion(walk_clip, import_bvh(path)[0])


def test_cmu_rig_in_t_pose(walk_clip, tmp_path):
    path = tmp_path / "walk.bvh"
    path.write_text(foreign_bvh_text(walk_clip, CGSPEED_CMU_NAMES, "y_up", body_scale=1.2, arm_out_deg=90.0))
    back, report = import_bvh(path)
    assert report["rig"] == "cmu" and report["folded_joints"] == 11  # the toes too: cmu names none
    assert_same_motion(walk_clip, back)


def test_own_names_on_other_proportions_are_retargeted(walk_clip, tmp_path):
    """The project's joint names with a 1.25x skeleton: not the exact path, the sfv preset."""
    lines = motion_to_bvh_text(walk_clip, "cm").split("\n")
    start = lines.index("MOTION") + 3
    for i, line in enumerate(lines):
        if line.strip().startswith("OFFSET"):
            head, numbers = line.split("OFFSET")
            lines[i] = head + "OFFSET " + " ".join(f"{1.25 * float(v):.6f}" for v in numbers.split())
        elif i >= start and line:
            values = line.split()
            lines[i] = " ".join([f"{1.25 * float(v):.6f}" for v in values[:3]] + values[3:])
    path = tmp_path / "big.bvh"
    path.write_text("\n".join(lines))
    back, report = import_bvh(path)
    assert report["rig"] == "sfv" and "exact" not in report
    assert report["leg_ratio"] == pytest.approx(0.8, rel=1e-4)
    assert_same_motion(walk_clip, back)


def test_unknown_names_need_a_map_file(walk_clip, tmp_path):
    bvh = tmp_path / "walk.bvh"
    bvh.write_text(foreign_bvh_text(walk_clip, UNREAL_NAMES, "z_up"))
    out = tmp_path / "walk.npz"
    assert main(["motion", "convert", str(bvh), "--out", str(out)]) == 2
    assert not out.exists()
    rig = tmp_path / "unreal.yaml"
    rig.write_text("joints:\n" + "".join(f"  {source}: {target}\n" for source, target in UNREAL_MAP.items()))
    assert main(["motion", "convert", str(bvh), "--out", str(out), "--rig", str(rig)]) == 0
    assert_same_motion(walk_clip, load_motion(out))
    json_rig = tmp_path / "unreal.json"
    json_rig.write_text(json.dumps(UNREAL_MAP))
    back, report = import_bvh(bvh, str(json_rig))
    assert report["rig"] == "unreal"
    assert_same_motion(walk_clip, back)


def test_convert_reports_what_it_did(walk_clip, tmp_path, capsys):
    bvh = tmp_path / "walk.bvh"
    bvh.write_text(foreign_bvh_text(walk_clip, MIXAMO_NAMES, "z_up"))
    assert main(["motion", "convert", str(bvh), "--out", str(tmp_path / "w.npz"), "--loop", "no"]) == 0
    report = json.loads(capsys.readouterr().out)
    retarget = report["retarget"]
    assert report["loop"] is False and retarget["loop"] is False
    # DeepMimic's walk sinks 5.3 mm; after the fit nothing is below the floor.
    assert retarget["penetration_before_m"] == pytest.approx(0.0053, abs=3e-4)
    assert retarget["penetration_after_m"] == 0.0
    # Skating is measured on the source and on the result the same way; the walk's is small.
    assert 0.0 < retarget["skating_source_mps"] < 0.1
    assert retarget["skating_mps"] == pytest.approx(retarget["skating_source_mps"], abs=0.01)


@pytest.mark.parametrize("units, per_metre", [("m", 1.0), ("mm", 1000.0), ("in", 1 / 0.0254)])
def test_units_are_told_by_the_skeleton_size(walk_clip, tmp_path, units, per_metre):
    path = tmp_path / "walk.bvh"
    path.write_text(foreign_bvh_text(walk_clip, MIXAMO_NAMES, "z_up", units_per_metre=per_metre))
    back, report = import_bvh(path)
    assert report["units"] == units and report["source_height_m"] == pytest.approx(1.638, abs=2e-3)
    assert_same_motion(walk_clip, back)


def test_given_axes_override_detection(walk_clip, tmp_path):
    path = tmp_path / "walk.bvh"
    path.write_text(foreign_bvh_text(walk_clip, MIXAMO_NAMES, "y_up"))
    back, report = import_bvh(path, options=RetargetOptions(up="+y", forward="+z", units="in"))
    assert (report["up"], report["forward"], report["units"]) == ("+y", "+z", "in")
    assert_same_motion(walk_clip, back)  # units only name the file's unit; sizes come from the legs
    wrong, _ = import_bvh(path, options=RetargetOptions(up="+y", forward="-z"))
    # The rest pose then faces backwards: the humanoid walks 1.2 m towards its heels.
    assert walk_clip.root_pos[-1, 0] > 1.0 and wrong.root_pos[-1, 0] < -1.0


def test_over_bent_knee_is_clipped_and_reported(walk_clip, tmp_path):
    joint_rot = walk_clip.joint_rot.copy()
    knee = JOINT_NAMES.index("right_knee")
    joint_rot[:, knee] = qn.quat_about_axis(np.full(len(joint_rot), 0.3), HINGE_AXIS)  # bent the wrong way
    bent = ReferenceMotion("bent", walk_clip.frame_times, walk_clip.root_pos, walk_clip.root_rot, joint_rot, True)
    path = tmp_path / "bent.bvh"
    path.write_text(foreign_bvh_text(bent, MIXAMO_NAMES, "z_up"))
    back, report = import_bvh(path)
    assert report["clipped_deg"]["right_knee"] == pytest.approx(np.degrees(0.3), abs=0.01)
    assert np.abs(qn.quat_angle(back.joint_rot[:, knee])).max() < 1e-6  # clipped to the straight knee


def test_ground_fit_puts_a_floating_clip_on_the_floor(walk_clip, tmp_path):
    floating = ReferenceMotion("f", walk_clip.frame_times, walk_clip.root_pos + [0, 0, 0.4], walk_clip.root_rot, walk_clip.joint_rot, True)
    path = tmp_path / "f.bvh"
    path.write_text(foreign_bvh_text(floating, MIXAMO_NAMES, "z_up"))
    back, report = import_bvh(path)
    assert report["floor_shift_m"] == pytest.approx(-0.3947, abs=1e-3)
    link_pos, link_rot = forward_kinematics(back.root_pos, back.root_rot, back.joint_rot)
    assert sole_heights(link_pos, link_rot).min() == pytest.approx(0.0, abs=1e-9)


def test_own_export_round_trips_through_convert(walk_clip, tmp_path, capsys):
    for units in ("cm", "m"):
        bvh = write_bvh(walk_clip, tmp_path / f"walk_{units}.bvh", units)
        out = tmp_path / f"walk_{units}.npz"
        assert main(["motion", "convert", str(bvh), "--out", str(out)]) == 0
        assert json.loads(capsys.readouterr().out)["retarget"] == {"rig": "sfv", "units": units, "exact": True, "loop": True}
        back = load_motion(out)
        assert rotation_error(walk_clip.joint_rot, back.joint_rot).max() < 1e-4
        assert rotation_error(walk_clip.root_rot, back.root_rot).max() < 1e-4
        np.testing.assert_allclose(back.root_pos, walk_clip.root_pos, atol=1e-6)


def test_train_and_check_accept_bvh(walk_clip, tmp_path, capsys):
    bvh = tmp_path / "walk.bvh"
    bvh.write_text(foreign_bvh_text(walk_clip, MIXAMO_NAMES, "z_up"))
    assert main(["motion", "check", str(bvh)]) == 0
    assert json.loads(capsys.readouterr().out)["playback_reward"] > 0.99
