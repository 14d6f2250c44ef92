"""Ray path == serial path: the same chunk function, run as real Ray tasks."""
from pathlib import Path

import cv2
import numpy as np
import pytest

from services.pose import estimate_video
from services.pose.video import read_frames

SHARED = Path(__file__).resolve().parents[3].parent / "shared"
CAM01 = SHARED / "data" / "video" / "pose2sim_balancing" / "cam01.mp4"


@pytest.fixture
def person_clip(tmp_path):
    if not CAM01.is_file():
        pytest.skip("../shared absent")
    path = tmp_path / "person.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 60.0, (540, 960))
    for index, frame in read_frames(CAM01, 0, 12):
        small = cv2.resize(frame, (540, 960), interpolation=cv2.INTER_AREA)
        if index == 6:  # no person here: filled alike on both paths
            small[:] = 0
        writer.write(cv2.cvtColor(small, cv2.COLOR_RGB2BGR))
    writer.release()
    return path


@pytest.mark.integration
@pytest.mark.shared
def test_ray_tasks_give_the_serial_answer(person_clip, models_dir):
    import ray

    serial = estimate_video(person_clip, models_dir=models_dir, use_ray=False, chunk_frames=4)
    # no Ray running yet: estimate_video starts a local one and shuts it down afterwards
    was_running = ray.is_initialized()
    distributed = estimate_video(person_clip, models_dir=models_dir, use_ray=True, chunk_frames=4)
    assert ray.is_initialized() == was_running
    assert len(distributed) == len(serial) == 12
    np.testing.assert_array_equal(distributed.valid, serial.valid)
    assert serial.filled_frames == distributed.filled_frames == 1
    np.testing.assert_allclose(distributed.keypoints2d, serial.keypoints2d, atol=1e-3)
    np.testing.assert_allclose(distributed.world3d, serial.world3d, atol=1e-5)
    np.testing.assert_array_equal(distributed.rotation_used, serial.rotation_used)
