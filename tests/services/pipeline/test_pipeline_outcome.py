"""report.json's one-line outcome: completed, or the first cause found (`services/pipeline/outcome.py`)."""
import numpy as np

from actors.motion.reference_motion import ReferenceMotion
from services.pipeline.outcome import outcome_line, toppling
from services.pipeline.rollout import BodyPoints, FirstFrameRollout

HZ = 30.0
FRAMES = 31


def _rollout(fell_at: int | None, sim_root=None, ref_root=None) -> FirstFrameRollout:
    ref = np.zeros((FRAMES, 35))
    ref[:, 2] = 0.9
    if ref_root is not None:
        ref[:, :3] = ref_root
    sim = ref.copy()
    if sim_root is not None:
        sim[:, :3] = sim_root
    return FirstFrameRollout(HZ, sim, ref, np.arange(FRAMES), FRAMES - 1, fell_at, False, 0.5, np.zeros(FRAMES - 1))


def _reconstruction(confidence: float = 0.9, contacts: bool = False, check: str = "") -> ReferenceMotion:
    identity = np.tile([1.0, 0.0, 0.0, 0.0], (FRAMES, 1))
    extras = {"confidence": np.full((FRAMES, 12), confidence), "contacts": np.full((FRAMES, 2), contacts)}
    if check:
        extras["reference_check"] = np.array(check)
    return ReferenceMotion("r", np.arange(FRAMES) / HZ, np.tile([0.0, 0.0, 0.9], (FRAMES, 1)), identity,
                           np.tile(identity[:, None], (1, 12, 1)), loop=False, extras=extras)


def _points(foot_height: float = 0.0) -> BodyPoints:
    return BodyPoints(np.zeros((FRAMES, 12, 3)), np.zeros((FRAMES, 2, 3)), np.full((FRAMES, 2), foot_height),
                      np.zeros(FRAMES))


ROWS = np.arange(FRAMES)


def test_completed_says_so():
    assert outcome_line(_rollout(None), _reconstruction(), ROWS, _points()) == \
        "completed: upright from the first frame to the clip's end (1.00 s)"


def test_a_rollout_toppling_at_the_clip_s_end_is_not_called_upright():
    rollout = _rollout(None)
    rollout.qpos[:, 3] = rollout.reference_qpos[:, 3] = 1.0  # upright, identity rotations
    half = np.radians(79.0) / 2  # the last frame tipped 79 degrees about x, as balancing cam01's body alone at 150 k
    rollout.qpos[-1, 3:7] = [np.cos(half), np.sin(half), 0.0, 0.0]
    line = outcome_line(rollout, _reconstruction(), ROWS, _points())
    assert line.startswith("completed the clip's frames (1.00 s), but toppling at its end: the pelvis 79 degrees off")
    assert toppling(rollout)
    half = np.radians(29.0) / 2  # leaning as far as the upright controllers measured do
    rollout.qpos[-1, 3:7] = [np.cos(half), np.sin(half), 0.0, 0.0]
    assert outcome_line(rollout, _reconstruction(), ROWS, _points()).startswith("completed: upright")
    assert not toppling(rollout)


def test_a_launch_at_the_start_is_the_first_cause():
    thrown = np.zeros((FRAMES, 3))
    thrown[:, 1] = np.arange(FRAMES) * 6.7 / HZ  # 6.7 m/s toward the camera, as two-people cam02 was
    thrown[:, 2] = 0.9
    line = outcome_line(_rollout(16, sim_root=thrown), _reconstruction(), ROWS, _points())
    assert line == ("fell at 0.53 s: first cause found: a launch at the start (root 6.7 m/s over the first 0.1 s; "
                    "reference 0.0 m/s)")


def test_an_unseen_subject_then_a_floating_contact_then_drift():
    assert "the subject barely seen before it (keypoint confidence 0.20 in video frames 5-20" in \
        outcome_line(_rollout(20), _reconstruction(confidence=0.2), ROWS, _points())
    assert "a contact foot 12 cm above the floor while called down" in \
        outcome_line(_rollout(20), _reconstruction(contacts=True), ROWS, _points(foot_height=0.12))
    assert "a contact foot" not in outcome_line(_rollout(20), _reconstruction(contacts=False), ROWS, _points(0.12))
    beside = np.tile([0.8, 0.0, 0.9], (FRAMES, 1))
    assert outcome_line(_rollout(20, sim_root=beside), _reconstruction(), ROWS, _points()).endswith(
        "drift (0.80 m from the reference's root at the fall)")
    assert outcome_line(_rollout(20), _reconstruction(), ROWS, _points()).startswith("fell at 0.67 s: no cause found")


def test_a_repair_is_a_cause_only_where_it_is_near_the_fall():
    """The park walk's body alone fell at 4.20 s, and the line blamed the repair of frames 89-97, 1.2 s before."""
    from services.pipeline.outcome import repaired_frames

    line = "reference check: ...; repaired the root in frames 3, 12-14 (now at most 1.20 m/s)"
    assert repaired_frames(line) == {3, 12, 13, 14}
    assert repaired_frames("reference check: nothing to repair") == set()
    near = outcome_line(_rollout(20), _reconstruction(check=line), ROWS, _points())  # window: frames 5-20
    assert near.endswith("a reference repaired just before it (the check re-placed its root in frames 12-14 of the clip)")
    far = outcome_line(_rollout(30), _reconstruction(check=line), ROWS, _points())  # window: frames 15-30
    assert "repaired" not in far and "no cause found" in far
