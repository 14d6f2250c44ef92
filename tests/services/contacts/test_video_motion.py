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


def test_a_start_read_from_a_half_hidden_body_is_left_out_and_said():
    """The first four frames' keypoints shrunk and thrown about (a body stepping out from behind
    a tree): the motion starts after them, reconstructed again, and says so."""
    clean = make_clip(frames=45, seed=1).track
    keypoints = clean.keypoints2d.copy()
    centre = keypoints[:4].mean(axis=1, keepdims=True)
    shrink = np.array([0.4, 0.7, 0.35, 0.6])[:, None, None]
    thrown = np.array([[120, -60], [-100, 40], [140, 30], [-60, -80]])[:, None, :]
    keypoints[:4] = centre + (keypoints[:4] - centre) * shrink + thrown
    lines = []
    made = video_motion(dataclasses.replace(clean, keypoints2d=keypoints.astype(clean.keypoints2d.dtype)), FAST, "clip",
                        "static", "clip.mp4", use_ray=False, say=lines.append)
    assert int(made.motion.extras["video_start_frame"]) == 4 and made.motion.num_frames == 41
    assert len(lines) == 1 and lines[0].startswith("subject frames: from frame 4 (the first 4 frames")
    assert list(made.motion.extras["subject_lines"]) == lines
    untouched = video_motion(clean, FAST, "clip", "static", "clip.mp4", use_ray=False)
    assert untouched.motion.num_frames == 45 and "subject_lines" not in untouched.motion.extras
