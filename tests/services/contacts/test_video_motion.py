"""The one path from a pose track to the motion file of `sfv reconstruct` and both `sfv pipeline`s:
cut to the subject, the learned contacts recorded (and fitted for a static camera), the video's
extras, root-free for a moving camera."""
import dataclasses

import numpy as np
import pytest

from services.contacts.video_motion import video_motion
from services.reconstruction import ReconstructionConfig
from services.reconstruction.synthetic import make_clip

FAST = ReconstructionConfig(iterations=30, ik_iterations=30, focal_length_px=600.0)
UNSEEN = 3  # the subject enters after this many frames


@pytest.fixture(scope="module")
def track():
    """A synthetic clip whose first frames have nobody in them."""
    track = make_clip(frames=16, seed=1).track
    valid, confidence = track.valid.copy(), track.confidence.copy()
    valid[:UNSEEN], confidence[:UNSEEN] = False, 0.0
    return dataclasses.replace(track, valid=valid, confidence=confidence)


def test_a_static_camera_motion_carries_contacts_and_where_it_starts_in_the_video(track):
    made = video_motion(track, FAST, "clip", "static", "clip.mp4", use_ray=False)
    extras = made.motion.extras
    assert not made.moving and made.motion.num_frames == len(track.valid) - UNSEEN
    assert int(extras["video_start_frame"]) == UNSEEN
    assert extras["contacts"].shape == extras["contact_probability"].shape == (made.motion.num_frames, 2)
    assert list(extras["contact_feet"]) == ["right", "left"]
    assert not bool(extras["camera_moving"]) and extras["orientation_hint"].shape == (made.motion.num_frames,)
    names = list(extras["final_loss_names"])
    fitted = extras["contacts"].any()
    assert (extras["final_losses"][names.index("contact")] > 0.0) == bool(fitted)


def test_a_moving_camera_keeps_the_contacts_as_cues_without_fitting_them(track):
    made = video_motion(track, FAST, "clip", "moving", "clip.mp4", use_ray=False)
    extras = made.motion.extras
    assert made.moving and bool(extras["root_free"]) and "contacts" in extras
    names = list(extras["final_loss_names"])
    assert extras["final_losses"][names.index("contact")] == 0.0
    assert np.allclose(made.motion.root_pos[:, :2], made.motion.root_pos[0, :2])


# 30 steps leave the synthetic walk's root jittering (median 2 m/s for 0.3 m/s, a 7.6 m/s jolt in
# its last half second); 60 settle it (median 1.5 m/s) so that only the thrown frames jolt.
SETTLED = dataclasses.replace(FAST, iterations=60)


def half_hidden(track, frames: slice):
    """The track with four frames' keypoints shrunk and thrown about (a body stepping out from
    behind a tree, or half out of the picture)."""
    keypoints = track.keypoints2d.copy()
    centre = keypoints[frames].mean(axis=1, keepdims=True)
    shrink = np.array([0.4, 0.7, 0.35, 0.6])[:, None, None]
    thrown = np.array([[120, -60], [-100, 40], [140, 30], [-60, -80]])[:, None, :]
    keypoints[frames] = centre + (keypoints[frames] - centre) * shrink + thrown
    return dataclasses.replace(track, keypoints2d=keypoints.astype(track.keypoints2d.dtype))


def test_a_start_read_from_a_half_hidden_body_is_left_out_and_said():
    """The motion starts after the four thrown frames, reconstructed again, and says so."""
    clean = make_clip(frames=45, seed=1).track
    lines = []
    made = video_motion(half_hidden(clean, slice(0, 4)), SETTLED, "clip", "static", "clip.mp4", use_ray=False,
                        say=lines.append)
    # The four thrown frames, and at most the two the root's smoothing spreads their jolt to (measured 6).
    start = int(made.motion.extras["video_start_frame"])
    assert 4 <= start <= 6 and made.motion.num_frames == 45 - start
    assert len(lines) == 1 and lines[0].startswith(f"subject frames: frames {start}-44 (the first {start} (")
    assert list(made.motion.extras["subject_lines"]) == lines


def test_an_end_read_from_a_body_leaving_the_view_is_left_out_and_said():
    """The same four frames at the clip's end (a walker half out of the picture): the motion ends
    before them. The check would repair their roots (extrapolated from the frames before), so the
    ends are judged on the reconstruction before it."""
    clean = make_clip(frames=45, seed=1).track
    lines = []
    made = video_motion(half_hidden(clean, slice(41, 45)), SETTLED, "clip", "static", "clip.mp4", use_ray=False,
                        say=lines.append)
    kept = made.motion.num_frames  # measured 39: the thrown four and two their jolt spreads to
    assert int(made.motion.extras["video_start_frame"]) == 0 and 39 <= kept <= 41
    assert len(lines) == 1 and lines[0].startswith(f"subject frames: frames 0-{kept - 1} (the last {45 - kept} (")
    untouched = video_motion(clean, SETTLED, "clip", "static", "clip.mp4", use_ray=False)
    assert untouched.motion.num_frames == 45 and "subject_lines" not in untouched.motion.extras


def test_a_subject_walking_out_at_the_side_of_the_picture_is_cut_before_the_reconstruction():
    """The park walker's last frames: her hips within 5 % of the picture's left side."""
    from services.pose.view_edges import at_the_sides

    clean = make_clip(frames=45, seed=1).track
    assert at_the_sides(clean) == (0, 0)
    keypoints = clean.keypoints2d.copy()
    width = float(clean.image_size[0])
    hips = keypoints[:, [23, 24], 0].mean(axis=1)
    keypoints[40:, :, 0] += (0.02 * width - hips[40:])[:, None]  # the last five frames: hips 2 % from the left side
    leaving = dataclasses.replace(clean, keypoints2d=keypoints.astype(clean.keypoints2d.dtype))
    assert at_the_sides(leaving) == (0, 5)
    lines = []
    made = video_motion(leaving, FAST, "clip", "static", "clip.mp4", use_ray=False, say=lines.append)
    assert made.motion.num_frames <= 40
    assert lines[0] == ("subject frames: frames 0-39 (the last 5 (0.17 s) are left out: the hips within 5 % of the "
                        "picture's side, half the body out of view); --frames A:B chooses others")
    everywhere = dataclasses.replace(clean, keypoints2d=(clean.keypoints2d * 0 + 0.01 * width).astype(clean.keypoints2d.dtype))
    assert at_the_sides(everywhere) == (0, 0)  # one who stays at the side is left whole
