"""Sliding windows of at most three objects (002 §5.3) and a window's own reference motion."""
from __future__ import annotations

import numpy as np
import pytest

from learner.errors import SfvError
from services.scene_fit.window_motion import window_motion
from services.scene_fit.windows import proportional_contact_frames, split_windows


def test_few_objects_make_one_window_over_the_clip():
    (window,) = split_windows(100, [(40, 1), (20, 0), (70, 2)])
    assert (window.start, window.control_end, window.end) == (0, 99, 99)
    assert window.boxes == (0, 1, 2)


def test_sliding_windows_overlap_by_one_stretch_and_hold_at_most_three_objects():
    events = [(10, 0), (30, 1), (50, 2), (70, 3), (90, 4)]
    windows = split_windows(120, events)
    assert len(windows) == 5
    for previous, current in zip(windows, windows[1:]):
        assert current.start == previous.control_end  # the next policy takes over where the last hands over
        assert current.start < previous.end  # and the windows overlap
    assert windows[0].start == 0 and windows[-1].control_end == windows[-1].end == 119
    assert all(len(w.boxes) <= 3 for w in windows)
    assert windows[2].boxes == (1, 2, 3)  # objects n-1, n, n+1
    covered = set()
    for w in windows:
        covered.update(range(w.start, w.control_end + 1))
    assert covered == set(range(120))  # the control segments cover the clip


def test_a_box_contacted_twice_counts_twice_and_close_contacts_merge():
    windows = split_windows(100, [(10, 0), (30, 1), (50, 0), (51, 2), (80, 1)], min_frames=3)
    starts = [w.start for w in windows]
    assert 51 not in starts and 50 in starts  # 51 is one frame after 50: merged into it
    assert windows[1].boxes == (0, 1)  # box 0 at 10 and 50, box 1 at 30


def test_contact_outside_the_clip_is_an_error():
    with pytest.raises(SfvError, match="box 2.*frame 130"):
        split_windows(100, [(10, 0), (130, 2)])


def test_proportional_contact_frames_keep_order_inside_the_clip():
    frames = proportional_contact_frames(np.array([0.5, 2.0, 1.0]), 91)
    assert frames[0] < frames[2] < frames[1] < 90 and frames.min() >= 0


def test_window_motion_cuts_frames_and_extras_and_moves_the_root():
    from actors.motion.formats.io import load_motion

    motion = load_motion("deepmimic:walk")
    motion.extras["contacts"] = np.arange(motion.num_frames * 2).reshape(-1, 2) % 2 == 0
    motion.extras["fps_note"] = np.array(3)
    window = split_windows(motion.num_frames, [(5, 0), (10, 1), (15, 2), (20, 3)])[1]
    cut = window_motion(motion, window, root_xy=np.array([2.0, -1.0]))
    assert cut.num_frames == window.frames and not cut.loop and cut.frame_times[0] == 0
    np.testing.assert_array_equal(cut.extras["contacts"], motion.extras["contacts"][window.start:window.end + 1])
    assert int(cut.extras["fps_note"]) == 3
    np.testing.assert_allclose(cut.root_pos[0, :2], [2.0, -1.0])
    drift = motion.root_pos[window.start:window.end + 1, :2] - motion.root_pos[window.start, :2]
    np.testing.assert_allclose(cut.root_pos[:, :2] - cut.root_pos[0, :2], drift)
    np.testing.assert_allclose(cut.joint_rot, motion.joint_rot[window.start:window.end + 1])


def test_control_steps_follow_time_not_clip_frames():
    from actors.motion.reference_motion import ReferenceMotion
    from services.scene_fit.window_motion import clip_frame, control_steps
    from services.scene_fit.windows import Window

    frames = 121  # 60 fps, 2 s
    identity = np.tile([1.0, 0.0, 0.0, 0.0], (frames, 1))
    motion = ReferenceMotion("m", np.arange(frames) / 60.0, np.zeros((frames, 3)), identity,
                             np.tile(identity[:, None], (1, 12, 1)))
    window = Window(0, 0, 90, 120, ())
    assert control_steps(window, motion, 30.0) == 45  # 1.5 s at 30 Hz
    assert clip_frame(Window(1, 30, 60, 120, ()), motion, 10, 30.0) == 30 + 20
