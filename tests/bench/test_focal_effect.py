"""bench/scripts/focal_effect.py: the calibration's camera (focal, centre, height, pitch) and the world measures."""
from __future__ import annotations

import tomllib

import numpy as np
import pytest

from tests.bench_scripts import load_bench_script


@pytest.fixture(scope="module")
def bench():
    return load_bench_script("focal_effect")


def _looking_down(pitch: float) -> np.ndarray:
    """World -> camera rotation of a camera looking along world +y, tilted `pitch` radians down
    (camera axes x right, y down, z forward; world z up)."""
    c, s = np.cos(pitch), np.sin(pitch)
    return np.array([[1.0, 0.0, 0.0], [0.0, -s, -c], [0.0, c, -s]])


def test_the_calibration_camera_is_placed_and_tilted_as_its_extrinsics_say(bench):
    import cv2

    rotation = _looking_down(np.radians(20.0))
    centre = np.array([0.5, -3.0, 1.8])
    calibration = {"matrix": [[1680.0, 0.0, 530.0], [0.0, 1676.0, 950.0], [0.0, 0.0, 1.0]],
                   "rotation": cv2.Rodrigues(rotation)[0].ravel().tolist(),
                   "translation": (-rotation @ centre).tolist()}
    camera = bench.calibration_camera(calibration)
    assert camera["focal_px"] == pytest.approx(1678.0)
    assert camera["principal_px"] == [530.0, 950.0]
    assert camera["position_m"] == pytest.approx(centre.tolist(), abs=1e-9)
    assert camera["height_m"] == pytest.approx(1.8, abs=1e-9)
    assert camera["pitch_deg"] == pytest.approx(20.0, abs=1e-9)
    # A point straight ahead on the optical axis, 4 m away, lies 4 m deep.
    ahead = centre + 4.0 * rotation[2]
    assert bench.depths(ahead[None], rotation, centre) == pytest.approx([4.0])
    assert bench.path_length(np.array([[0.0, 0.0, 0.0], [3.0, 4.0, 0.0], [3.0, 4.0, 1.0]])) == pytest.approx(6.0)


def test_the_pose2sim_calibration_reads_as_the_lab_camera(bench, shared_dir):
    path = shared_dir / "data" / "video" / "pose2sim_balancing" / "Calib_qualisys.toml"
    if not path.is_file():
        pytest.skip(f"{path} absent")
    camera = bench.calibration_camera(tomllib.loads(path.read_text())["cam_01"])
    assert 1670.0 < camera["focal_px"] < 1690.0  # 14 % shorter than the default max(1080, 1920)
    assert 1.5 < camera["height_m"] < 2.2 and 10.0 < camera["pitch_deg"] < 40.0  # above the floor, looking down
