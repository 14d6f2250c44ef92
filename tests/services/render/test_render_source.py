"""`sfv render-motion --source`: the source skeleton drawn beside the retargeted humanoid."""
from __future__ import annotations

import numpy as np
import pytest

from services.cli import main
from tests.foreign_rig import MIXAMO_NAMES, foreign_bvh_text


def _orange(pixels: np.ndarray) -> np.ndarray:
    return (pixels[..., 0] > 170) & (pixels[..., 2] < 100) & (pixels[..., 0] - pixels[..., 1] > 70)


def _blue(pixels: np.ndarray) -> np.ndarray:
    return (pixels[..., 2] > 170) & (pixels[..., 0] < 110)


def test_source_skeleton_beside_the_humanoid(walk_clip, tmp_path, capsys):
    imageio = pytest.importorskip("imageio.v2")
    bvh = tmp_path / "walk.bvh"
    bvh.write_text(foreign_bvh_text(walk_clip, MIXAMO_NAMES, "y_up"))
    npz, video = tmp_path / "walk.npz", tmp_path / "side.mp4"
    assert main(["motion", "convert", str(bvh), "--out", str(npz)]) == 0
    assert main(["render-motion", str(npz), "--source", str(bvh), "--out", str(video), "--height", "240"]) == 0
    assert "38 frames" in capsys.readouterr().out  # 1.27 s at 30 fps
    frame = imageio.get_reader(video).get_data(10).astype(int)
    assert frame.shape == (240, 320, 3)
    source, humanoid = frame[:, :160], frame[:, 160:]
    # The right side (orange) and the left side (blue) of the stick figure, only in its panel.
    assert _orange(source).sum() > 30 and _blue(source).sum() > 30
    assert _orange(humanoid).sum() == 0 and _blue(humanoid).sum() == 0
    # The camera follows the humanoid and the skeleton stands on it: both near the panel's middle.
    columns = np.argwhere(_orange(source) | _blue(source))[:, 1]
    assert 40 < columns.mean() < 120


def test_broken_source_writes_nothing(walk_clip, tmp_path, capsys):
    bvh = tmp_path / "walk.bvh"
    bvh.write_text(foreign_bvh_text(walk_clip, MIXAMO_NAMES, "y_up").replace("mixamorig:", "bone_"))
    npz, video = tmp_path / "walk.npz", tmp_path / "side.mp4"
    from actors.motion.formats.io import save_motion

    save_motion(walk_clip, npz)
    assert main(["render-motion", str(npz), "--source", str(bvh), "--out", str(video)]) == 2
    assert "cannot map this rig" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["walk.bvh", "walk.npz"]
