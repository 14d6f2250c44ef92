"""The motion distance ranks the mocap above standing still, and both far above jittered and
flailing movement (the pose density ranked standing above the mocap)."""
import numpy as np
import pytest

from services.tasks.motion_likeness import MotionLibrary, window_features
from services.tasks.pose_prior import PosePrior, clip_poses


@pytest.fixture(scope="module")
def library():
    return MotionLibrary.fit()


def test_mocap_ranks_above_standing_and_both_above_jitter_and_flailing(library):
    rng = np.random.default_rng(0)
    walk = clip_poses("walk")
    standing = walk[:1].repeat(90, axis=0)
    mocap = library.score([clip_poses(c) for c in library.clips])
    jitter = library.score([walk + rng.normal(0.0, 0.1, walk.shape)])
    flailing = library.score([rng.uniform(-1.0, 1.0, (90, 28))])
    assert mocap < 1e-6 < library.score([standing]) < jitter < flailing
    # the pose density, fitted to the same clips, puts standing above the mocap
    prior = PosePrior.fit()
    assert prior.log_density(standing).mean() > np.mean([prior.log_density(clip_poses(c)).mean() for c in prior.clips])


def test_reference_lines_bracket_what_a_policy_is_read_against(library):
    lines = library.reference_distances()
    assert lines["standing_still"] < lines["mocap_held_out"]
    # a walk slowed to half speed is not in the library, and reads nearer than a clip held out
    walk = clip_poses("walk")
    assert 0.0 < library.score([np.repeat(walk, 2, axis=0)]) < lines["mocap_held_out"]


def test_sequences_shorter_than_a_window_give_no_score(library):
    assert window_features(np.zeros((5, 28)), 1).shape[0] == 0
    assert library.score([np.zeros((5, 28))]) is None
