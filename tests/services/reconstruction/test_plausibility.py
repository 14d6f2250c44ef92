"""The reference check: root launches no body makes are flagged and repaired before training."""
import numpy as np
import pytest

from actors.motion.reference_motion import ReferenceMotion
from services.reconstruction.plausibility import (
    bad_frames,
    check_reference,
    flag_steps,
    local_medians,
    repaired_root,
    root_speeds,
)

FPS = 60.0


def _standing(frames: int = 60, seed: int = 0) -> np.ndarray:
    """A root that stands with 5 mm of jitter: well under every rule."""
    rng = np.random.default_rng(seed)
    root = np.tile([0.0, 0.0, 0.9], (frames, 1))
    return root + rng.normal(0.0, 0.005, root.shape)


def _motion(root: np.ndarray, extras: dict | None = None) -> ReferenceMotion:
    frames = len(root)
    identity = np.tile([1.0, 0.0, 0.0, 0.0], (frames, 1))
    return ReferenceMotion(name="t", frame_times=np.arange(frames) / FPS, root_pos=root, root_rot=identity,
                           joint_rot=np.tile(identity[:, None], (1, 12, 1)), loop=False, extras=extras or {})


def test_local_median_is_shifted_inward_at_the_ends_so_an_edge_spike_is_not_its_own_median():
    speeds = np.array([13.4, 4.5, 4.4, 3.0, 1.6, 0.9, 0.3, 0.3, 0.2, 0.3, 0.2])
    medians = local_medians(speeds, 9)
    assert medians[0] < 2.0 and medians[0] == medians[4]  # rows 0..8 for the first five
    assert np.isclose(medians[-1], np.median(speeds[-9:]))


def test_a_standing_root_with_jitter_is_left_alone():
    root = _standing()
    motion = _motion(root)
    checked, check = check_reference(motion)
    assert checked is motion and check.repaired_frames.size == 0
    assert "nothing to repair" in check.line


def test_the_first_frame_launch_is_repaired_and_said_in_one_line():
    root = _standing()
    # the two-people cam02 woman before the ROI fix: 0.22 m toward the camera in frame 0, then converging
    root[0, 1] -= 0.22
    root[1, 1] -= 0.075
    root[2, 1] -= 0.003
    keypoints = np.repeat(root[:, None], 12, axis=1) + 0.3
    checked, check = check_reference(_motion(root, {"keypoints3d": keypoints.copy()}))
    assert check.repaired_frames.tolist()[:1] == [0]
    assert "between frames 0 and 1" in check.line and "repaired the root in frames 0" in check.line
    assert "\n" not in check.line
    jitter = root_speeds(_standing(), FPS).max()  # 1.2 m/s at most from the 5 mm jitter
    assert root_speeds(root, FPS).max() > 8 and root_speeds(checked.root_pos, FPS).max() <= jitter
    assert np.linalg.norm(checked.sample(0.0).root_lin_vel) < jitter  # the start velocity training would use
    # world keypoints moved with the root
    np.testing.assert_allclose(checked.extras["keypoints3d"] - checked.root_pos[:, None], keypoints - root[:, None])


def test_a_spike_inside_is_interpolated_and_the_good_frames_kept():
    root = _standing()
    root[30, 1] += 0.15  # one frame 15 cm off: 9 m/s out and back
    checked, check = check_reference(_motion(root))
    assert check.repaired_frames.tolist() == [30]
    np.testing.assert_allclose(checked.root_pos[30], (root[29] + root[31]) / 2)
    untouched = np.setdiff1d(np.arange(len(root)), [30])
    np.testing.assert_array_equal(checked.root_pos[untouched], root[untouched])


def test_both_feet_down_contradicts_a_fast_root():
    frames = 40
    root = np.zeros((frames, 3))
    root[:, 0] = np.arange(frames) * 2.0 / FPS  # a steady 2 m/s: no spike
    root[:, 2] = 0.9
    contacts = np.zeros((frames, 2), bool)
    assert not any(f.any() for f in flag_steps(root, FPS, contacts).values())
    contacts[10:20] = True
    flags = flag_steps(root, FPS, contacts)
    assert np.flatnonzero(flags["both feet down"]).tolist() == list(range(10, 19))
    assert not flags["spike"].any()


def test_end_frames_are_extrapolated_at_the_good_velocity():
    frames = 30
    root = np.zeros((frames, 3))
    root[:, 0] = np.arange(frames) * 1.0 / FPS  # walking 1 m/s
    bad = np.zeros(frames, bool)
    bad[-3:] = True
    fixed = repaired_root(root + np.where(bad[:, None], 5.0, 0.0), bad, FPS)
    np.testing.assert_allclose(fixed, root, atol=1e-12)


def test_a_lone_step_inside_spreads_over_the_frames_at_its_ends():
    flagged = np.zeros(20, bool)
    flagged[10] = True
    assert np.flatnonzero(bad_frames(flagged)).tolist() == [10, 11]
    flagged[:] = True
    assert not bad_frames(flagged).any()  # nothing good to repair from


def test_a_repaired_frame_keeps_its_lowest_joint_at_the_height_of_its_neighbours():
    root = _standing()
    keypoints = np.repeat(root[:, None], 12, axis=1)
    keypoints[:, :, 2] -= np.linspace(0.0, 0.8, 12)  # lowest joint 0.8 m below the root: 10 cm above the floor
    root[30] += [0.0, 0.15, 0.1]  # a spike 15 cm deeper and 10 cm higher ...
    keypoints[30] += [0.0, 0.15, 0.1 - 0.2]  # ... its lowest joint 1.0 m below its root (0.8 elsewhere), at the floor
    checked, check = check_reference(_motion(root, {"keypoints3d": keypoints}))
    assert check.repaired_frames.tolist() == [30]
    lowest = checked.extras["keypoints3d"][..., 2].min(axis=1)
    assert lowest[30] == pytest.approx((lowest[29] + lowest[31]) / 2)  # on the neighbours' height, not sunk
    assert checked.root_pos[30, 2] == pytest.approx(lowest[30] + 1.0)  # the pose kept: the root 1.0 m above it
    assert lowest[30] > 0.05  # interpolating the root's own height would have left it at the floor


def test_a_run_of_wrong_frames_at_the_start_is_repaired_to_the_walk_after_it():
    """The park walk behind a pole: her first four frames, half behind a tree, put the root off
    by decreasing amounts (7.8 m/s steps), and a two-frame spike follows; the first pass's local
    median at the start is those steps' own, so it flags only the spike."""
    frames, fps = 60, 30.0
    root = np.column_stack((-1.2 * np.arange(frames) / fps, np.zeros(frames), np.full(frames, 0.9)))
    root[:4, 0] += [0.9, 0.68, 0.45, 0.22]
    root[5:7, 0] += 1.0
    motion = ReferenceMotion(name="t", frame_times=np.arange(frames) / fps, root_pos=root,
                             root_rot=np.tile([1.0, 0.0, 0.0, 0.0], (frames, 1)),
                             joint_rot=np.tile([1.0, 0.0, 0.0, 0.0], (frames, 12, 1)), loop=False, extras={})
    assert not flag_steps(root, fps, None)["spike"][:3].any()  # the start's steps are their own median at first
    checked, check = check_reference(motion)
    assert {0, 1, 2, 5, 6} <= set(check.repaired_frames.tolist())
    assert root_speeds(checked.root_pos, fps).max() < 3.0  # no launch: the walk's pace within a couple of m/s
    assert np.linalg.norm(checked.sample(0.0).root_lin_vel) < 3.0


def test_an_unsettled_start_is_found_and_a_walk_that_starts_at_once_is_not():
    """Frames read while the subject steps out from behind a tree: the root jolts there."""
    from services.reconstruction.plausibility import EDGE_DV_M_S, unsettled_start

    frames = 60
    walk = np.column_stack((-1.2 * np.arange(frames) / FPS, np.zeros(frames), np.full(frames, 0.9)))
    walk[:, 2] += 0.02 * np.sin(2 * np.pi * 2.0 * np.arange(frames) / FPS)  # the stride's bob
    assert unsettled_start(_motion(walk))[0] == 0
    jolted = walk.copy()
    jolted[:5, 0] += [0.6, 0.2, 0.55, 0.1, 0.3]  # a half-hidden body, read five ways
    cut, change = unsettled_start(_motion(jolted))
    assert change > EDGE_DV_M_S and cut == 6  # up to the last jolt (frame 5's velocity against frame 4's), inclusive
    assert unsettled_start(_motion(jolted[cut:]))[0] == 0


def test_an_unsettled_end_is_found_and_cut_as_the_start_is():
    """A subject leaving the view at the frame's edge: the last frames' root jolts, the start's does not."""
    from services.reconstruction.plausibility import EDGE_DV_M_S, unsettled_end, unsettled_start

    frames = 60
    walk = np.column_stack((1.2 * np.arange(frames) / FPS, np.zeros(frames), np.full(frames, 0.9)))
    assert unsettled_end(_motion(walk))[0] == 0
    leaving = walk.copy()
    leaving[-3:, 1] += [0.4, 1.5, 0.2]  # half a body, read metres off in depth
    tail, change = unsettled_end(_motion(leaving))
    assert change > EDGE_DV_M_S and tail == 4  # from the first jolt (frame 57's velocity against 56's) to the end
    assert unsettled_end(_motion(leaving[:-tail]))[0] == 0
    assert unsettled_start(_motion(leaving))[0] == 0


def _walk(frames: int, fps: float, speed: float = 1.1) -> np.ndarray:
    return np.column_stack((-speed * np.arange(frames) / fps, np.zeros(frames), np.full(frames, 0.9)))


def test_an_excursion_out_and_back_is_repaired_though_its_steps_are_their_own_median(monkeypatch):
    """The park walk where she passes the man: the root goes 0.6 m off in depth and back over nine
    frames, at 4-5 m/s a step, so the spike rule's local median is raised by the excursion itself."""
    from services.reconstruction import plausibility
    from services.reconstruction.plausibility import OFF_PATH_M

    fps = 30.0
    root = _walk(141, fps)
    root[88:97, 1] += [0.17, 0.35, 0.53, 0.6, 0.6, 0.45, 0.3, 0.15, 0.03]
    assert root_speeds(root, fps)[88:96].max() > 5.0
    with monkeypatch.context() as patch:  # the spike rule alone leaves most of it
        patch.setattr(plausibility, "OFF_PATH_M", np.inf)
        spikes_only, _ = check_reference(_motion_at(root, fps))
    assert root_speeds(spikes_only.root_pos, fps).max() > 5.0 and np.abs(spikes_only.root_pos[:, 1]).max() > 0.5
    checked, check = check_reference(_motion_at(root, fps))
    assert "leaves the path" in check.line and "\n" not in check.line
    assert set(range(89, 94)) <= set(check.repaired_frames.tolist())
    assert np.abs(checked.root_pos[:, 1]).max() < OFF_PATH_M / 2  # back on her path
    assert root_speeds(checked.root_pos, fps).max() < 2.5
    np.testing.assert_array_equal(checked.root_pos[:80], root[:80])  # frames away from it untouched


@pytest.mark.parametrize("shape", ["turn", "sprint", "cut"])
def test_a_path_that_bends_or_speeds_up_is_not_an_excursion(shape):
    """A walker who turns round, a sprinter's start (0 to 8 m/s in 1.5 s) and side-to-side cuts at
    6 m/s^2 follow smooth paths: none of their frames is off the path, though the cuts swing 0.4 m."""
    from services.reconstruction.plausibility import OFF_PATH_M, path_residuals

    fps = 30.0
    t = np.arange(300) / fps
    root = np.column_stack((np.zeros_like(t), np.zeros_like(t), np.full_like(t, 0.9)))
    if shape == "turn":  # 1.1 m/s out, the turn in about a second, 1.1 m/s back
        velocity = 1.1 * np.tanh((5.0 - t) / 0.3)
        root[:, 0] = np.cumsum(velocity) / fps
    elif shape == "sprint":
        root[:, 0] = np.cumsum(np.clip(t / 1.5, 0.0, 1.0) * 8.0) / fps
    else:
        root[:, 0] = 1.5 * t
        lateral = np.cumsum(np.cumsum(np.where((t // 0.5) % 2 == 0, 6.0, -6.0)) / fps) / fps
        root[:, 1] = lateral - np.linspace(lateral[0], lateral[-1], len(t))
        assert np.ptp(root[:, 1]) > OFF_PATH_M
    root += np.random.default_rng(0).normal(0.0, 0.01, root.shape)  # 1 cm of reconstruction jitter
    assert path_residuals(root, fps).max() < OFF_PATH_M
    assert check_reference(_motion_at(root, fps))[1].repaired_frames.size == 0


def _motion_at(root: np.ndarray, fps: float) -> ReferenceMotion:
    frames = len(root)
    identity = np.tile([1.0, 0.0, 0.0, 0.0], (frames, 1))
    return ReferenceMotion(name="t", frame_times=np.arange(frames) / fps, root_pos=root, root_rot=identity,
                           joint_rot=np.tile(identity[:, None], (1, 12, 1)), loop=False, extras={})
