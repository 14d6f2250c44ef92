"""A later window's scene: the same boxes in the world, seen from the window's first frame."""
from __future__ import annotations

import numpy as np
import pytest

scene_module = pytest.importorskip("actors.arenas.scene")


def test_boxes_stay_put_in_the_world_and_observe_the_same(tmp_path):
    from actors.motion.formats.io import load_motion
    from services.scene_fit import scene_contract
    from services.scene_fit.window_motion import window_motion
    from services.scene_fit.window_scene import window_scene
    from services.scene_fit.windows import Window

    clip = load_motion("deepmimic:walk")
    clip.loop = False
    path = tmp_path / "s.yaml"
    path.write_text("boxes:\n  - name: a\n    along: 2.0\n    height: 0.2\n    size: [0.5, 0.8]\n"
                    "  - name: b\n    along: 3.0\n    lateral: 0.4\n    height: 0.1\n    size: [0.5, 0.8]\n")
    scene = scene_contract.load_scene(path)
    motion = window_motion(clip, Window(1, 10, 20, 30, (0,)), root_xy=np.array([0.9, 0.05]))
    placed, shift = window_scene(scene, clip, motion)
    clip_frame, frame = scene_module.SceneFrame.of_motion(clip), scene_module.SceneFrame.of_motion(motion)
    for before, after in zip(scene.boxes, placed.boxes):
        np.testing.assert_allclose(frame.to_world(after.along, after.lateral), clip_frame.to_world(before.along, before.lateral), atol=1e-9)
    np.testing.assert_allclose(placed.vector(), scene.vector() + shift)
    assert shift[0] < 0 and shift[1] == 0.0  # the window starts nearer the box
    e = scene.vector() + np.array([0.1, 0.05, -0.2, 0.02])
    np.testing.assert_allclose(placed.normalise(e + shift), scene.normalise(e))  # what the networks see
    np.testing.assert_allclose(scene_contract.scene_obs(scene).entries(e), scene.normalise(e))
    written = scene_contract.write_scene_yaml(placed, tmp_path / "w.yaml")
    np.testing.assert_allclose(scene_contract.load_scene(written).vector(), placed.vector())
