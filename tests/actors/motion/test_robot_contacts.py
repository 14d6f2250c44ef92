"""Which feet the retargeter holds on the ground: a reconstruction's learned contacts, else the
foot-contact rule on the source's ankles (no robot model needed)."""
import numpy as np

from actors.character.kinematics import forward_kinematics
from actors.character.skeleton import LINK_NAMES
from actors.motion.robot_retarget import source_contacts


def _sampled(motion):
    pos, _ = forward_kinematics(motion.root_pos, motion.root_rot, motion.joint_rot)
    return motion.frame_times, pos


def test_the_rule_finds_the_walks_alternating_stance(walk_clip):
    times, pos = _sampled(walk_clip)
    contacts = source_contacts(walk_clip, times, pos, band=0.02)  # left, right
    assert contacts.shape == (walk_clip.num_frames, 2)
    assert 0.3 < contacts.mean() < 0.7 and contacts[:, 0].any() and contacts[:, 1].any()
    left = pos[:, LINK_NAMES.index("left_ankle"), 2]
    assert left[contacts[:, 0]].max() < left[~contacts[:, 0]].min()  # down is lower than up


def test_learned_contacts_of_a_reconstruction_win_and_are_reordered(walk_clip):
    import dataclasses

    learned = np.zeros((walk_clip.num_frames, 2), dtype=bool)  # the file's order: right, left
    learned[:5, 0] = True
    learned[10:, 1] = True
    motion = dataclasses.replace(walk_clip, extras={**walk_clip.extras, "contacts": learned})
    times, pos = _sampled(motion)
    contacts = source_contacts(motion, times, pos, band=0.02)
    assert np.array_equal(contacts, learned[:, ::-1])
