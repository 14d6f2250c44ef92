"""The root-path estimate of root-free motions (`services/reconstruction/root_path.py`) on DeepMimic
clips whose root path is thrown away, and its place in the motion file."""
from __future__ import annotations

import numpy as np
import pytest

from actors.character import quaternion as qn
from actors.motion.formats.io import load_motion, root_path_estimate, save_motion
from actors.motion.reference_motion import MotionFormatError, ReferenceMotion
from services.reconstruction.root_free import make_root_free
from services.reconstruction.root_path import camera_yaw, estimate_root_path, motion_root_path, root_path_extras, sole_points

pytest.importorskip("pybullet_data")  # the DeepMimic clips (the mocap extra)

FPS = 30.0


def sampled(clip: str, seconds: float):
    """The clip at 30 fps (looped), its root-relative sole corners and contacts from foot height
    and speed (a sole within 5 cm of the floor, slower than 1.5 m/s)."""
    motion = load_motion(f"deepmimic:{clip}")
    times = np.arange(0.0, seconds + 1e-9, 1.0 / FPS)
    pose = motion.sample(times)
    points = sole_points(pose.root_rot, pose.joint_rot)
    world = pose.root_pos[:, None, None] + points
    speed = np.linalg.norm(np.gradient(world.mean(axis=2)[..., :2], times, axis=0), axis=-1)
    contacts = ((world[..., 2].min(axis=2) < 0.05) & (speed < 1.5)).astype(np.float64)
    return times, pose, points, contacts


def travelled(root: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(root[:, :2], axis=0), axis=1).sum())


def test_a_straight_walk_is_recovered_within_a_few_percent():
    times, pose, points, contacts = sampled("walk", 6.0)
    path = estimate_root_path(points, contacts, times, pose.root_pos[0, :2]).position
    distance = travelled(pose.root_pos)
    assert distance > 5.0  # the clip walks; the estimate sees none of it
    end_error = np.linalg.norm(path[-1, :2] - pose.root_pos[-1, :2])
    assert end_error < 0.03 * distance
    assert np.linalg.norm(path[:, :2] - pose.root_pos[:, :2], axis=1).max() < 0.1
    assert np.abs(path[:, 2] - pose.root_pos[:, 2]).max() < 0.05  # standing on the floor


def flight_gaps(contacts: np.ndarray) -> list[tuple[int, int]]:
    """(last frame down, first frame down again) around each run of frames with no foot down."""
    down = (contacts > 0.5).any(axis=1)
    gaps, t = [], 1
    while t < len(down):
        if not down[t] and down[t - 1]:
            end = t + np.argmax(down[t:]) if down[t:].any() else len(down)
            if end < len(down):
                gaps.append((t - 1, end))
            t = end
        t += 1
    return gaps


def test_a_jumps_flight_is_bridged_by_a_ballistic_arc():
    times, pose, points, contacts = sampled("jump", 1.77)
    path = estimate_root_path(points, contacts, times, pose.root_pos[0, :2])
    a, b = max(flight_gaps(contacts), key=lambda gap: gap[1] - gap[0])
    assert times[b] - times[a] > 0.3  # the jump's flight, not a stumble
    z = path.position[a:b + 1, 2]
    dt = 1.0 / FPS
    np.testing.assert_allclose(np.diff(z, 2), -9.81 * dt * dt, atol=1e-9)  # falls under gravity
    assert z.max() > max(z[0], z[-1]) + 0.15  # it rises: a straight bridge would not
    assert abs(z.max() - pose.root_pos[a:b + 1, 2].max()) < 0.05  # the mocap's apex, 1.13 m
    assert np.abs(np.diff(path.position[:, 2])).max() < 0.1  # no jump in height at take-off or landing


def test_confidence_is_lower_where_the_contacts_are_missing():
    times, pose, points, contacts = sampled("walk", 6.0)
    missing = contacts.copy()
    short, long = slice(60, 69), slice(120, 165)  # 0.33 s and 1.5 s without a foot down
    missing[short] = 0.0
    missing[long] = 0.0
    missing[:15] = 0.0  # nothing before the first contact
    confidence = estimate_root_path(points, missing, times, pose.root_pos[0, :2]).confidence
    held = estimate_root_path(points, contacts, times, pose.root_pos[0, :2]).confidence
    assert held[15:].min() == pytest.approx(1.0)
    assert confidence[short].max() < 0.6
    assert confidence[long].max() < confidence[short].min()
    assert confidence[:14].max() == 0.0
    path = estimate_root_path(points, missing, times, pose.root_pos[0, :2]).position
    assert np.abs(path[long, 2] - pose.root_pos[long, 2]).max() < 0.1  # a long gap is no 1.5 s parabola


def test_a_panning_camera_is_turned_back_by_its_pan():
    times, pose, points, contacts = sampled("walk", 6.0)
    focal, pan = 1000.0, np.full(len(times), 6.0)  # the view turns right 6 px a frame
    turned = -camera_yaw(pan, np.ones(len(times)), focal)  # a static-camera fit shows the world turned so
    assert turned[-1] > 1.0  # more than 57 degrees over the clip
    spin = qn.quat_about_axis(turned, np.array([0.0, 0.0, 1.0]))
    fitted = ReferenceMotion("fitted", times, pose.root_pos, qn.quat_mul(spin, pose.root_rot), pose.joint_rot,
                             extras={"contacts": contacts > 0.5})
    distance = travelled(pose.root_pos)
    bent = motion_root_path(fitted, turn_by_pan=True).position
    fitted.extras.update(camera_pan_px=pan, camera_zoom=np.ones(len(times)), camera_intrinsics=np.diag([focal, focal, 1.0]))
    straight = motion_root_path(fitted, turn_by_pan=True).position
    assert np.allclose(motion_root_path(fitted).position, bent)  # the stored path does not turn (TURN_BY_PAN)
    assert np.linalg.norm(bent[-1, :2] - pose.root_pos[-1, :2]) > 0.3 * distance
    assert np.linalg.norm(straight[-1, :2] - pose.root_pos[-1, :2]) < 0.03 * distance


def root_free_walk() -> ReferenceMotion:
    times, pose, _, contacts = sampled("walk", 2.0)
    motion = ReferenceMotion("walk_video", times, pose.root_pos, pose.root_rot, pose.joint_rot,
                             extras={"contact_probability": contacts, "contacts": contacts > 0.5})
    return make_root_free(motion)


def test_the_motion_file_keeps_the_root_path_and_loads_files_without_it(tmp_path):
    motion = root_free_walk()
    motion.extras.update(root_path_extras(motion))
    loaded = load_motion(str(save_motion(motion, tmp_path / "with.npz")))
    path, confidence = root_path_estimate(loaded)
    np.testing.assert_array_equal(path, motion.extras["root_path"])
    np.testing.assert_array_equal(confidence, motion.extras["root_path_confidence"])
    assert travelled(path) > 1.5 and travelled(loaded.root_pos) < 1e-9  # the file's root stays free

    older = root_free_walk()
    loaded = load_motion(str(save_motion(older, tmp_path / "without.npz")))
    assert root_path_estimate(loaded) is None
    assert set(loaded.extras) == set(older.extras)
    assert root_path_extras(ReferenceMotion("mocap", older.frame_times, older.root_pos, older.root_rot, older.joint_rot)) == {}


def test_a_root_path_of_the_wrong_length_is_refused_naming_the_file(tmp_path):
    motion = root_free_walk()
    motion.extras.update(root_path=np.zeros((motion.num_frames - 1, 3)), root_path_confidence=np.ones(motion.num_frames))
    path = save_motion(motion, tmp_path / "bad.npz")
    with pytest.raises(MotionFormatError, match=r"bad\.npz: 'root_path' has shape"):
        load_motion(str(path))
    with pytest.raises(ValueError, match="contacts have shape"):
        motion_root_path(motion, np.ones((motion.num_frames, 3)))


def test_a_moving_camera_reconstruction_writes_the_estimated_path():
    from services.contacts.video_motion import video_motion
    from services.reconstruction import ReconstructionConfig
    from services.reconstruction.synthetic import make_clip

    track = make_clip(frames=16, seed=1).track
    fast = ReconstructionConfig(iterations=30, ik_iterations=30, focal_length_px=600.0)
    made = video_motion(track, fast, "clip", "moving", "clip.mp4", use_ray=False)
    extras, frames = made.motion.extras, made.motion.num_frames
    assert extras["root_path"].shape == (frames, 3) and extras["root_path_confidence"].shape == (frames,)
    np.testing.assert_allclose(extras["root_path"][0, :2], made.motion.root_pos[0, :2])
    down = np.asarray(extras["contact_probability"]).max(axis=1) >= 0.5
    assert (extras["root_path_confidence"][down] >= 0.5).all() and (extras["root_path_confidence"][~down] < 1.0).all()
