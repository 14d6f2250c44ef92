"""Scene files (actors/arenas/scene.py): the example loads, every fault is one line naming the file
and the box, and the scene vector round-trips."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from actors.motion.formats.io import load_motion
from actors.arenas.scene import SceneError, load_scene

REPO = Path(__file__).resolve().parents[3]
CLIP = REPO / "bench" / "scenes" / "box_jump.npz"
GOOD = """boxes:
  - name: step
    along: 1.1
    height: 0.2
    size: [1.0, 1.0]
"""


def _write(tmp_path, text: str) -> Path:
    path = tmp_path / "scene.yaml"
    path.write_text(text)
    return path


def test_the_example_files_load_and_the_guess_domain_holds_the_truth():
    truth = load_scene(REPO / "bench" / "scenes" / "box_jump_truth.yaml", load_motion(str(CLIP)))
    guess = load_scene(REPO / "bench" / "scenes" / "box_jump.yaml", load_motion(str(CLIP)))
    low, high = guess.bounds()
    assert np.all(low <= truth.vector()) and np.all(truth.vector() <= high)
    assert not np.allclose(guess.vector(), truth.vector())


def test_defaults_and_the_vector_round_trip(tmp_path):
    scene = load_scene(_write(tmp_path, GOOD))
    box = scene.boxes[0]
    assert box.lateral == 0.0 and box.along_domain == pytest.approx((0.8, 1.4)) and box.height_domain == pytest.approx((0.0, 0.5))
    e = np.array([1.3, 0.05])
    moved = scene.with_vector(e)
    np.testing.assert_allclose(moved.vector(), e)
    np.testing.assert_allclose(scene.normalise(scene.bounds()[0]), [-1.0, -1.0])
    np.testing.assert_allclose(scene.normalise(scene.bounds()[1]), [1.0, 1.0])
    draws = np.stack([scene.sample(np.random.default_rng(s)) for s in range(50)])
    assert np.all(draws >= scene.bounds()[0]) and np.all(draws <= scene.bounds()[1]) and draws.std(axis=0).min() > 0.05


@pytest.mark.parametrize("text, fault", [
    (GOOD.replace("    height: 0.2\n", "    height: 0.2\n    domain: {height: [0.3, 0.5]}\n"), "height 0.2 is outside its domain"),
    (GOOD.replace("    along: 1.1\n", "    along: 1.1\n    colour: red\n"), "unknown key 'colour'"),
    (GOOD.replace("along: 1.1", "along: far"), "along must be a finite number"),
    (GOOD.replace("size: [1.0, 1.0]", "size: [1.0]"), "size must be a list of two numbers"),
    (GOOD.replace("size: [1.0, 1.0]", "size: [1.0, -1.0]"), "size must be two lengths > 0"),
    (GOOD.replace("    height: 0.2\n", ""), "missing height"),
    (GOOD.replace("height: 0.2", "height: -0.1"), "height must be >= 0"),
    (GOOD.replace("    height: 0.2\n", "    height: 0.2\n    domain: {along: [1.4, 0.8]}\n"), "has min above max"),
    ("boxes: []\n", "non-empty list"),
    ("box: {}\n", "one key, boxes"),
    (GOOD + GOOD.replace("boxes:\n", ""), "name 'step' is used twice"),
])
def test_each_fault_is_one_line_naming_the_file_and_the_box(tmp_path, text, fault):
    path = _write(tmp_path, text)
    with pytest.raises(SceneError) as info:
        load_scene(path)
    message = str(info.value)
    assert fault in message and str(path) in message and "\n" not in message
    if "step" in text and "boxes: []" not in text and "box: {}" not in text:
        assert "'step'" in message


def test_a_box_that_can_reach_the_start_pose_is_refused(tmp_path):
    motion = load_motion(str(CLIP))
    near = _write(tmp_path, GOOD.replace("along: 1.1", "along: 0.75"))  # the domain reaches back to 0.45, the box to -0.05
    with pytest.raises(SceneError, match=r"box 'step' overlaps the start pose"):
        load_scene(near, motion)
    load_scene(_write(tmp_path, GOOD), motion)  # 0.8 - 0.5 = 0.3 m ahead: clear


def test_missing_and_unparsable_files_are_one_line(tmp_path):
    with pytest.raises(SceneError, match="cannot read scene file"):
        load_scene(tmp_path / "absent.yaml")
    with pytest.raises(SceneError, match="not valid YAML"):
        load_scene(_write(tmp_path, "boxes: [\n"))


def test_the_scene_flag_is_absolute_so_a_resume_from_elsewhere_matches(tmp_path, monkeypatch):
    import argparse

    from actors.envs.imitation_env import EnvConfig
    from services.training import flags
    from services.training.config import TrainConfig

    path = _write(tmp_path, GOOD)
    monkeypatch.chdir(tmp_path)
    parser = argparse.ArgumentParser()
    flags.add_config_flags(parser)
    given, used = flags.given_settings(parser.parse_args(["--scene", path.name]))
    assert given == {"env.scene": str(path)}
    base = TrainConfig(env=EnvConfig(scene=path.name)).to_dict()  # saved configs hold the absolute path too
    assert flags.resolve(given, used, base, resuming=True).env.scene == str(path)
    with pytest.raises(Exception, match="--scene: cannot change on --resume"):
        flags.resolve({"env.scene": str(tmp_path / "other.yaml")}, used, base, resuming=True)
