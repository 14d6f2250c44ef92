"""Several people: identities across frames, chunks and gaps; choosing the subject.

The videos are built from the real Pose2Sim footage (tests/people_clips.py) and skip where
../shared is absent; the identity rules are also checked on hand-made tables.
"""
import numpy as np
import pytest

from learner.errors import SfvError
from services.cli import main
from services.pose import PoseConfig, PoseTrack
from services.pose.identity import link_chunks, relink_gaps
from services.pose.people_chunk import PeopleChunk, PeopleRows
from services.pose.pipeline import estimate_people
from services.pose.subject import (
    PersonChoice,
    choose_subject,
    crop_to_seen,
    parse_frames,
    parse_person_at,
    subject_track,
)
from tests.people_clips import A_LEFT, CAM01, STRIP, _quarter_strips, two_people_clip, write_clip

STRIP_WIDTH = STRIP.stop - STRIP.start


@pytest.fixture(scope="module")
def two_people(tmp_path_factory, models_dir):
    if not CAM01.is_file():
        pytest.skip("../shared absent: the two-person clip is made from the Pose2Sim video")
    clip = two_people_clip(tmp_path_factory.mktemp("people") / "two.avi")
    # chunks of 25 frames: identities must survive three chunk boundaries
    return clip, estimate_people(clip.path, models_dir=models_dir, chunk_frames=25)


def _hips_x(rows: PeopleRows, person: int) -> tuple[np.ndarray, np.ndarray]:
    mine = rows.person == person
    return rows.frame[mine], rows.keypoints2d[mine][:, 23:25, 0].mean(axis=1)


@pytest.mark.shared
def test_two_people_keep_apart_across_chunks_and_one_leaves(two_people):
    clip, people = two_people
    summaries = people.people()
    assert [s.person for s in summaries] == [0, 1]  # 0 is the leftmost at frame 0
    frames_a, hips_a = _hips_x(people.rows, 0)
    frames_b, hips_b = _hips_x(people.rows, 1)
    # A: every frame, always on its own strip, one identity through all chunk boundaries
    np.testing.assert_array_equal(frames_a, np.arange(clip.frames))
    assert ((hips_a > A_LEFT) & (hips_a < A_LEFT + STRIP_WIDTH)).all()
    # B: from the start until it has left; always on its own (moving) strip, never on A's
    assert frames_b[0] == 0 and frames_b[-1] < clip.b_gone_from and frames_b[-1] >= clip.b_gone_from - 10
    np.testing.assert_array_equal(frames_b, np.arange(frames_b[-1] + 1))
    inside = frames_b[clip.b_left[frames_b] + STRIP_WIDTH <= 640]  # wholly in the picture
    on_strip = np.abs(hips_b[inside] - (clip.b_left[inside] + STRIP_WIDTH / 2)) < STRIP_WIDTH / 2
    assert on_strip.all() and (hips_b > A_LEFT + STRIP_WIDTH).all()
    # default subject: seen longest
    assert choose_subject(people, PersonChoice(), "two.avi") == 0


@pytest.mark.shared
def test_the_subject_track_covers_only_its_own_frames(two_people):
    clip, people = two_people
    track = subject_track(people, 1)
    assert len(track) == clip.frames and track.person_id == 1
    last_seen = int(np.flatnonzero(track.valid).max())
    assert not track.valid[last_seen + 1:].any()
    cropped = crop_to_seen(track, "two.avi")
    assert len(cropped) == last_seen + 1 and cropped.start_frame == 0 and cropped.valid.all()
    # never another person's pose: B's hips stay right of A's strip in every frame
    assert (cropped.keypoints2d[:, 23:25, 0].mean(axis=1) > A_LEFT + STRIP_WIDTH).all()


@pytest.mark.shared
def test_person_at_and_unknown_person(two_people):
    clip, people = two_people
    b_hip_x = float(clip.b_left[10] + STRIP_WIDTH / 2)
    assert choose_subject(people, PersonChoice(at=(b_hip_x, 240.0, 10)), "two.avi") == 1
    assert choose_subject(people, PersonChoice(at=(A_LEFT + STRIP_WIDTH / 2, 240.0, 90)), "two.avi") == 0
    with pytest.raises(SfvError, match=r"--person 7: no such person in two\.avi \(ids 0, 1"):
        choose_subject(people, PersonChoice(person=7), "two.avi")
    with pytest.raises(SfvError, match=r"--person-at 600,20@90: nobody in two\.avi covers that pixel"):
        choose_subject(people, PersonChoice(at=(600.0, 20.0, 90)), "two.avi")
    with pytest.raises(SfvError, match="outside the estimated frames 0..99"):
        choose_subject(people, PersonChoice(at=(10.0, 10.0, 500)), "two.avi")


@pytest.mark.shared
def test_a_teleport_is_a_gap_between_two_identities_not_a_jump(tmp_path, models_dir):
    """The same person cut from the left to the right of the picture: the track must end and
    a new identity begin, never one identity that jumps."""
    if not CAM01.is_file():
        pytest.skip("../shared absent")
    strips = _quarter_strips(40)
    frames = []
    for t, strip in enumerate(strips):
        canvas = np.full((480, 640, 3), 110, np.uint8)
        left = 20 if t < 20 else 420
        canvas[:, left:left + STRIP_WIDTH] = strip
        frames.append(canvas)
    people = estimate_people(write_clip(tmp_path / "cut.avi", frames), models_dir=models_dir, chunk_frames=15)
    for summary in people.people():
        _, hips = _hips_x(people.rows, summary.person)
        assert np.ptp(hips) < 200, f"identity {summary.person} jumps across the picture"
    sides = {(s.first_frame, s.last_frame) for s in people.people() if s.frames_seen >= 5}
    assert any(last == 19 for _, last in sides) and any(first >= 20 for first, _ in sides)


@pytest.mark.shared
def test_cli_lists_people_writes_the_sheet_and_follows_the_chosen_one(two_people, models_dir, tmp_path, capsys):
    import cv2

    clip, _ = two_people
    sheet, out = tmp_path / "people.png", tmp_path / "b.npz"
    assert main(["pose", str(clip.path), "--serial", "--pose-models", str(models_dir), "--people", str(sheet),
                 "--person", "1", "--frames", "10:60", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "person 0: frames 10-59" in printed and "person 1: frames 10-59" in printed and "<- subject" in printed
    image = cv2.imread(str(sheet))
    assert image.shape[0] == 2 * (200 + 22) and image.shape[1] == 3 * 160
    track = PoseTrack.load(out)
    assert len(track) == 50 and track.start_frame == 10 and track.person_id == 1 and track.valid.all()
    assert main(["pose", str(clip.path), "--serial", "--pose-models", str(models_dir), "--person", "5",
                 "--out", str(tmp_path / "none.npz")]) == 2
    assert "--person 5: no such person" in capsys.readouterr().err and not (tmp_path / "none.npz").exists()


# ------------------------------------------------------------------ identity rules on tables
def _rows(entries):
    """entries: (frame, person, hip_x); a 33-point 'pose' spread around (hip_x, 200)."""
    offsets = np.linspace(-40, 40, 33)[:, None] * np.array([[0.3, 1.0]])
    rows = []
    for frame, person, x in entries:
        rows.append((frame, person, offsets + (x, 200.0)))
    n = len(rows)
    return PeopleRows(frame=np.array([r[0] for r in rows], np.int32), person=np.array([r[1] for r in rows], np.int32),
                      keypoints2d=np.array([r[2] for r in rows], np.float32), confidence=np.ones((n, 33), np.float32),
                      world3d=np.zeros((n, 33, 3), np.float32), presence=np.ones(n, np.float32),
                      rotation_used=np.zeros(n, np.int16), roi_size=np.full(n, 100.0, np.float32))


def test_chunks_continue_identities_on_their_shared_warmup_frames():
    config = PoseConfig(warmup_frames=2)
    still = (np.repeat(np.eye(3)[None], 4, axis=0), np.zeros(4, np.int32))
    first = PeopleChunk(0, 0, 4, _rows([(f, 0, 100.0) for f in range(4)] + [(f, 1, 300.0) for f in range(4)]), *still)
    # the next chunk's local ids are swapped, and a third person appears after the boundary
    second = PeopleChunk(4, 2, 4, _rows([(f, 0, 301.0) for f in range(2, 8)] + [(f, 1, 101.0) for f in range(2, 8)]
                                        + [(f, 2, 500.0) for f in range(5, 8)]), *still)
    rows = link_chunks([first, second], config)
    assert sorted(set(rows.frame.tolist())) == list(range(8))  # warm-up rows of the second chunk dropped
    for frame in range(8):
        here = {int(p): float(x) for p, x in zip(rows.person[rows.frame == frame],
                                                  rows.keypoints2d[rows.frame == frame][:, 16, 0])}
        assert abs(here[0] - 100) < 2 and abs(here[1] - 300) < 2
    assert set(rows.person[rows.frame >= 5].tolist()) == {0, 1, 2}


def test_gaps_rejoin_one_person_but_never_two_seen_together():
    config = PoseConfig()
    # person 0 vanishes for 3 frames and returns in place (new local id 2); person 1 is at
    # the same spot as 0's return but seen together with 0 earlier: must stay separate
    rows = _rows([(f, 0, 100.0) for f in range(5)] + [(f, 2, 102.0) for f in range(8, 12)]
                 + [(f, 1, 400.0) for f in range(12)] + [(f, 3, 402.0) for f in range(14, 16)])
    joined = relink_gaps(rows, fps=30.0, config=config)
    ids_by_x = {}
    for person in np.unique(joined.person):
        xs = joined.keypoints2d[joined.person == person][:, 16, 0]
        ids_by_x[int(person)] = (float(xs.min()), float(xs.max()), int((joined.person == person).sum()))
    assert sorted(ids_by_x.values()) == [(100.0, 102.0, 9), (400.0, 402.0, 14)]
    # a gap longer than relink_gap_s starts a new identity
    far = relink_gaps(_rows([(f, 0, 100.0) for f in range(3)] + [(f, 1, 100.0) for f in range(40, 43)]), 30.0, config)
    assert len(np.unique(far.person)) == 2


def test_frame_and_pixel_flags_parse_or_say_what_is_wrong():
    assert parse_frames("10:60") == (10, 60) and parse_frames(":5") == (0, 5) and parse_frames("7:") == (7, None)
    assert parse_person_at("320,240@12") == (320.0, 240.0, 12)
    with pytest.raises(SfvError, match="--frames '60:10': the end must come after the start"):
        parse_frames("60:10")
    with pytest.raises(SfvError, match="--frames 'ten': expected A:B"):
        parse_frames("ten")
    with pytest.raises(SfvError, match=r"--person-at '320x240': expected X,Y@FRAME"):
        parse_person_at("320x240")


def test_old_pose_track_files_load_with_the_whole_video_and_person_zero(tmp_path):
    frames = 3
    old = {"fps": np.array(30.0), "image_size": np.array([64, 48]), "keypoints2d": np.zeros((frames, 33, 2), np.float32),
           "confidence": np.ones((frames, 33), np.float32), "world3d": np.zeros((frames, 33, 3), np.float32),
           "valid": np.ones(frames, bool), "presence": np.ones(frames, np.float32),
           "rotation_used": np.zeros(frames, np.int16), "filled_frames": np.array(0),
           "keypoint_names": np.array(PoseTrack.__dataclass_fields__["keypoint_names"].default)}
    np.savez(tmp_path / "old.npz", **old)
    track = PoseTrack.load(tmp_path / "old.npz")
    assert track.start_frame == 0 and track.person_id == 0 and len(track) == frames


def test_a_subject_lost_for_most_of_its_span_is_refused():
    frames = 10
    valid = np.zeros(frames, bool)
    valid[[0, 9]] = True
    track = PoseTrack(fps=30.0, image_size=(64, 48), keypoints2d=np.zeros((frames, 33, 2), np.float32),
                      confidence=np.zeros((frames, 33), np.float32), world3d=np.zeros((frames, 33, 3), np.float32),
                      valid=valid, presence=valid.astype(np.float32), rotation_used=np.zeros(frames, np.int16),
                      filled_frames=8, person_id=3)
    with pytest.raises(SfvError, match=r"v\.mp4: the subject \(person 3\) is lost in 8 of the 10 frames it spans"):
        crop_to_seen(track, "v.mp4")
    track.valid = np.zeros(frames, bool)
    track.valid[4] = True
    with pytest.raises(SfvError, match=r"seen in 1 frame\(s\); a motion needs at least 2"):
        crop_to_seen(track, "v.mp4")
    track.valid[2:8] = True  # seen in 6 of frames 2..7, lost in none: kept, cropped to them
    cropped = crop_to_seen(track, "v.mp4")
    assert len(cropped) == 6 and cropped.start_frame == 2 and cropped.filled_frames == 0


def test_a_gap_over_a_second_cuts_the_track_to_the_stretch_seen_longest():
    frames = 120  # 30 fps: seen 0-49, unseen 1.5 s, seen 95-99, unseen 0.3 s, seen 110-111 (the park demo's man)
    valid = np.zeros(frames, bool)
    valid[0:50] = valid[95:100] = valid[110:112] = True
    valid[20:30] = False  # a third of a second behind a tree: stays inside the motion, interpolated
    track = PoseTrack(fps=30.0, image_size=(64, 48), keypoints2d=np.zeros((frames, 33, 2), np.float32),
                      confidence=np.zeros((frames, 33), np.float32), world3d=np.zeros((frames, 33, 3), np.float32),
                      valid=valid, presence=valid.astype(np.float32), rotation_used=np.zeros(frames, np.int16),
                      filled_frames=int((~valid).sum()), start_frame=7, person_id=0)
    lines = []
    cropped = crop_to_seen(track, "park.mp4", lines.append)
    assert (cropped.start_frame, len(cropped), cropped.filled_frames) == (7, 50, 10)
    assert lines == ["subject frames: 7-56 (person 0 is unseen for 1.5 s from frame 57; a gap over 1 s is not interpolated unless the person moves on "
                     "across it as before, and the motion covers the stretch seen longest); --frames A:B chooses another"]
    track.valid[0:47] = False  # the first stretch now holds 3 seen frames, the later one (95-111) 13: it is kept
    track.valid[100:106] = True
    assert crop_to_seen(track, "park.mp4").start_frame == 7 + 95


def _walker_track(frames: int, hidden: slice, reappear_shift=(0.0, 0.0), reappear_scale=1.0) -> PoseTrack:
    """A person 300 px tall crossing the image at 10 px per frame, hidden in `hidden`; after it,
    moved by `reappear_shift` px and scaled by `reappear_scale` (a jump down, a step closer)."""
    t = np.arange(frames, dtype=np.float64)
    body = np.zeros((33, 2))
    body[:, 1] = np.linspace(-150.0, 150.0, 33)  # 300 px from head to feet; the hips (23, 24) at +59 px
    keypoints = np.repeat(body[None], frames, axis=0)
    after = np.arange(frames) >= hidden.stop
    keypoints[after] *= reappear_scale
    keypoints[..., 0] += (1500.0 - 10.0 * t)[:, None]
    keypoints[..., 1] += 600.0
    keypoints[after] += reappear_shift
    valid = np.ones(frames, bool)
    valid[hidden] = False
    confidence = np.where(valid[:, None], 0.9, 0.0).astype(np.float32).repeat(33, axis=1)
    return PoseTrack(fps=30.0, image_size=(1920, 1080), keypoints2d=keypoints.astype(np.float32), confidence=confidence,
                     world3d=np.zeros((frames, 33, 3), np.float32), valid=valid, presence=valid.astype(np.float32),
                     rotation_used=np.zeros(frames, np.int16), filled_frames=int((~valid).sum()), person_id=6)


def test_a_walker_hidden_longer_than_a_second_who_moves_on_as_before_is_interpolated():
    """The park walk behind a pole: hidden 1.5 s, she reappears where her pace takes her."""
    lines = []
    track = _walker_track(150, slice(50, 95))
    cropped = crop_to_seen(track, "pole.mp4", lines.append)
    assert (cropped.start_frame, len(cropped), cropped.filled_frames) == (0, 150, 45)
    assert lines == ["subject gaps interpolated: person 6 is unseen for 1.50 s from frame 50 (over 1 s, but moving on across it as before it)"]
    # Reappearing half a body lower, or 1.5 times as large, is no walk behind a pole: cut as before.
    for changed in (_walker_track(150, slice(50, 95), reappear_shift=(0.0, 150.0)),
                    _walker_track(150, slice(50, 95), reappear_scale=1.5)):
        lines.clear()
        cropped = crop_to_seen(changed, "pole.mp4", lines.append)
        assert (cropped.start_frame, len(cropped)) == (95, 55) and lines[0].startswith("subject frames: 95-149")
    # Beyond the identity join's reach (3 s) a gap is never interpolated.
    assert len(crop_to_seen(_walker_track(250, slice(50, 150)), "pole.mp4")) == 100


def test_coasting_never_makes_a_motion_that_is_mostly_guessed():
    """Hidden 1.83 s of a 3-s clip: joined, more than half of it would be interpolated, so the
    gap cuts the track as it did before coasting (the longer seen stretch is kept)."""
    lines = []
    cropped = crop_to_seen(_walker_track(90, slice(20, 75)), "pole.mp4", lines.append)
    assert (cropped.start_frame, len(cropped), cropped.filled_frames) == (0, 20, 0)
    assert len(lines) == 1 and lines[0].startswith("subject frames: 0-19 (person 6 is unseen for 1.8 s from frame 20")
