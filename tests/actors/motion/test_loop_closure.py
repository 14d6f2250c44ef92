"""Closing a looped clip's wrap (actors/motion/loop_closure.py)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from actors.character import quaternion as qn
from actors.motion.loop_closure import close_loop, wrap_mismatch
from actors.motion.reference_motion import ReferenceMotion

Z = np.array([0.0, 0.0, 1.0])
X = np.array([1.0, 0.0, 0.0])


def _swing(loop: bool = True, mismatch: float = 0.4) -> ReferenceMotion:
    """A 2 s clip at 30 fps: every joint swings about x, ending `mismatch` rad past its start;
    the root turns 0.3 rad in heading and tilts 0.2 rad about x over the clip."""
    t = np.linspace(0.0, 2.0, 61)
    angle = 0.3 * np.sin(np.pi * t) + mismatch * t / 2.0
    joint = np.broadcast_to(qn.quat_about_axis(angle, X)[:, None], (61, 12, 4)).copy()
    root = qn.quat_mul(qn.quat_about_axis(0.15 * t, Z), qn.quat_about_axis(0.1 * t, X))
    pos = np.stack((0.5 * t, np.zeros_like(t), np.full_like(t, 0.9)), axis=1)
    return ReferenceMotion("swing", t, pos, root, joint, loop=loop)


def _angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return qn.quat_angle(qn.quat_mul(qn.quat_conj(a), b))


def test_the_ends_meet_halfway_and_the_middle_is_untouched():
    motion = _swing()
    closed = close_loop(motion, blend_s=0.5)
    assert wrap_mismatch(motion).max() == pytest.approx(0.4, abs=1e-6)
    assert wrap_mismatch(closed).max() < 1e-6
    change = _angles(motion.joint_rot, closed.joint_rot).max(axis=1)
    assert change[0] == pytest.approx(0.2, abs=1e-6) and change[-1] == pytest.approx(0.2, abs=1e-6)
    middle = (motion.frame_times > 0.5) & (motion.frame_times < 1.5)
    assert change[middle].max() < 1e-9
    # The tilt closes, the heading and the root's path stay.
    tilt = lambda q: qn.quat_mul(qn.quat_conj(qn.heading_quat(q)), q)  # noqa: E731
    assert _angles(tilt(closed.root_rot[-1:]), tilt(closed.root_rot[:1]))[0] < 1e-6
    np.testing.assert_allclose(qn.heading_angle(closed.root_rot), qn.heading_angle(motion.root_rot), atol=1e-9)
    np.testing.assert_array_equal(closed.root_pos, motion.root_pos)


def test_the_closed_clip_plays_smoothly_across_the_wrap():
    # Sampled at 120 Hz through the wrap, the largest step is the clip's own motion, not a jump.
    motion, closed = _swing(), close_loop(_swing(), blend_s=0.5)
    times = np.arange(1.5, 2.5, 1 / 120)
    for clip, bound in ((motion, 0.3), (closed, 0.03)):
        joint = clip.sample(times).joint_rot[:, 0]
        steps = _angles(joint[:-1], joint[1:])
        assert (steps.max() > bound) == (clip is motion), (clip is motion, steps.max())


def test_clips_that_do_not_loop_and_a_zero_blend_are_left_alone():
    for motion, blend in ((_swing(loop=False), 0.5), (_swing(), 0.0)):
        assert close_loop(motion, blend) is motion


def test_the_blend_is_capped_at_half_the_clip():
    closed = close_loop(_swing(), blend_s=10.0)
    assert wrap_mismatch(closed).max() < 1e-6
    change = _angles(_swing().joint_rot, closed.joint_rot).max(axis=1)
    assert change[30] < 1e-9  # the middle frame (1.0 s) still untouched


def test_motion_check_reports_an_open_loop(tmp_path, capsys):
    from actors.motion.formats.io import save_motion
    from services.cli import main

    path = save_motion(_swing(mismatch=0.4), tmp_path / "swing.npz")
    assert main(["motion", "check", str(path)]) == 0
    assert json.loads(capsys.readouterr().out)["loop_wrap_mismatch_rad"] == pytest.approx(0.4, abs=1e-3)


def test_the_env_imitates_the_closed_clip_when_asked():
    from actors.envs.imitation_env import EnvConfig, ImitationEnv
    from actors.envs.initial_states import BufferedStarts, ReferenceStarts
    from actors.envs.vector_env import VectorImitationEnv

    motion = _swing()
    open_env, closed_env = ImitationEnv(motion, EnvConfig()), ImitationEnv(motion, EnvConfig(loop_closure_s=0.5))
    assert wrap_mismatch(open_env.motion).max() == pytest.approx(0.4, abs=1e-6)
    assert wrap_mismatch(closed_env.motion).max() < 1e-6
    # The track the env reads is the closed one: the body's pose (links relative to the root,
    # heading frame) steps across the wrap as far as across any control step, not by the mismatch.
    wrap = closed_env.track.start_steps  # row t = duration: the next pass's first frame

    def steps(env):
        pose = env.track.pose_obs
        return np.abs(pose[wrap] - pose[wrap - 1]).max(), np.abs(pose[wrap - 1] - pose[wrap - 2]).max()

    across, before = steps(closed_env)
    assert across < 2 * before, (across, before)
    across, before = steps(open_env)
    assert across > 4 * before, (across, before)
    batch = VectorImitationEnv(motion, EnvConfig(loop_closure_s=0.5), 2, BufferedStarts(ReferenceStarts("rsi", np.random.default_rng(0))))
    assert all(env.motion is batch.envs[0].motion for env in batch.envs) and wrap_mismatch(batch.envs[0].motion).max() < 1e-6
    with pytest.raises(ValueError, match="loop_closure_s must be >= 0"):
        EnvConfig(loop_closure_s=-1.0)
