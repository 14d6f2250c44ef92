"""The default subject: of the people seen throughout, the one who performs (moves most), said
in one line with the `--person` that changes it; a new person's first frame from a settled ROI."""
import numpy as np
import pytest

from services.pose.activity import person_activity
from services.pose.people_chunk import PeopleRows
from services.pose.subject import PeopleTrack, PersonChoice, choose_subject, subject_reason
from tests.conftest import SHARED

TWO_PEOPLE_CAM02 = SHARED / "data" / "video" / "pose2sim_two_people" / "cam02.mp4"
BASE = np.stack([np.linspace(-0.3, 0.3, 33), np.linspace(-1.0, 1.0, 33)], axis=1)  # a 33-point body, unit height


def _person(person: int, frames: range, centre_x: float, size: float, swing: float) -> list:
    """Rows of one person: a body `size` px tall whose wrists and ankles swing by `swing` px a frame."""
    rows = []
    for frame in frames:
        points = BASE * size + (centre_x, 500.0)
        points[[15, 16, 27, 28], 0] += swing * (-1) ** frame
        rows.append((frame, person, points, size))
    return rows


def _people(*persons) -> PeopleTrack:
    rows = [r for p in persons for r in p]
    n = len(rows)
    table = PeopleRows(frame=np.array([r[0] for r in rows], np.int32), person=np.array([r[1] for r in rows], np.int32),
                       keypoints2d=np.array([r[2] for r in rows], np.float32), confidence=np.ones((n, 33), np.float32),
                       world3d=np.zeros((n, 33, 3), np.float32), presence=np.ones(n, np.float32),
                       rotation_used=np.zeros(n, np.int16), roi_size=np.array([r[3] for r in rows], np.float32))
    return PeopleTrack(fps=60.0, image_size=(1088, 1920), start_frame=0, frame_count=100, rows=table,
                       camera_homography=np.full((100, 3, 3), np.nan), camera_inliers=np.zeros(100))


def test_the_performer_is_chosen_over_a_larger_bystander_and_a_passer_by():
    bystander = _person(0, range(100), 200.0, 1100.0, 0.0)  # largest, seen in every frame, still
    performer = _person(1, range(1, 100), 600.0, 1000.0, 20.0)  # seen in 99, swings arms and legs
    passer_by = _person(2, range(60), 900.0, 800.0, 60.0)  # moves most but leaves after 60 frames
    people = _people(bystander, performer, passer_by)
    assert choose_subject(people, PersonChoice(), "cam.mp4") == 1
    line = subject_reason(people, 1, PersonChoice())
    assert line.startswith("subject: person 1 of 3 (seen throughout and moves most")
    assert "person 0's 0.0" in line and "--person 0 / 2" in line and "\n" not in line
    assert choose_subject(people, PersonChoice(person=0), "cam.mp4") == 0
    assert "(--person 0)" in subject_reason(people, 0, PersonChoice(person=0))
    # nobody moves: the larger of those seen throughout, as before
    assert choose_subject(_people(_person(0, range(100), 200.0, 900.0, 0.0),
                                  _person(1, range(100), 600.0, 1000.0, 0.0)), PersonChoice(), "cam.mp4") == 1


def test_activity_is_in_body_sizes_per_second_and_ignores_unconfident_points():
    rows = _person(0, range(10), 300.0, 500.0, 50.0)
    frames = np.array([r[0] for r in rows])
    points = np.array([r[2] for r in rows])
    confidence = np.ones((10, 33))
    # 4 of the 22 body points swing +-50 px, i.e. move 100 px a frame (hips still): 4/22 * 100 / 500 * 60 /s
    assert person_activity(frames, points, confidence, 500.0, 60.0) == pytest.approx(4 / 22 * 100 / 500 * 60)
    confidence[:, [15, 16, 27, 28]] = 0.1
    assert person_activity(frames, points, confidence, 500.0, 60.0) == 0.0
    assert person_activity(frames[::2], points[::2], confidence[::2], 500.0, 60.0) == 0.0  # no consecutive frames


@pytest.mark.shared
def test_two_people_cam02_follows_the_man_and_the_woman_starts_settled(models_dir):
    if not TWO_PEOPLE_CAM02.is_file():
        pytest.skip("../shared absent: needs the Pose2Sim two-people video")
    from services.pose.pipeline import estimate_people

    people = estimate_people(TWO_PEOPLE_CAM02, models_dir=models_dir)
    summaries = {s.person: s for s in people.people()}
    # person 0: the woman standing at the left edge (larger); person 1: the man on the force plates
    assert summaries[0].size_px > summaries[1].size_px
    assert choose_subject(people, PersonChoice(), "cam02") == 1  # measured 4.0 against 0.7 body sizes/s
    assert summaries[1].activity > 3 * summaries[0].activity
    rows = people.rows
    woman = rows.keypoints2d[rows.person == 0][:6]
    height = woman[:, :, 1].max(axis=1) - woman[:, :, 1].min(axis=1)
    # from the detector's ROI her first frame was 611 px tall against 736-759 in frames 1-5
    assert height[0] > 0.95 * np.median(height[1:])
