"""`sfv plot`: learning curves from real run directories' metrics.jsonl, decoded back as pixels."""
from __future__ import annotations

import json

import imageio.v2 as imageio
import numpy as np
import pytest

from services.cli import main
from services.training.curves import INIT_COLOURS, plot_learning_curves, smooth
from services.training.run_dir import CONFIG_FILE, METRICS_FILE


def make_run(path, init: str, returns) -> None:
    path.mkdir(parents=True)
    (path / CONFIG_FILE).write_text(json.dumps({"init": init, "motion": "deepmimic:walk"}))
    lines = [json.dumps({"samples": 4096 * (k + 1), "normalized_return": r}) for k, r in enumerate(returns)]
    lines.insert(1, json.dumps({"samples": 4096, "normalized_return": None}))  # an iteration without episodes
    (path / METRICS_FILE).write_text("\n".join(lines) + "\n{\"cut by a kill")


def colour_pixels(png, name: str) -> int:
    from matplotlib.colors import to_rgb

    target = np.array(to_rgb(name)) * 255
    image = imageio.imread(png)[..., :3].astype(float)
    return int((np.abs(image - target).max(axis=-1) < 12).sum())


@pytest.fixture
def runs(tmp_path):
    rising = np.linspace(0.05, 0.8, 40)
    make_run(tmp_path / "walk_asi", "asi", rising)
    make_run(tmp_path / "walk_rsi", "rsi", rising * 0.7)
    return tmp_path


def test_plot_draws_one_coloured_line_per_init(runs, tmp_path, capsys):
    out = tmp_path / "curves.png"
    assert main(["plot", str(runs / "walk_asi"), str(runs / "walk_rsi"), "--out", str(out)]) == 0
    assert json.loads(capsys.readouterr().out)["points"] == {str(runs / "walk_asi"): 40, str(runs / "walk_rsi"): 40}
    image = imageio.imread(out)
    assert image.shape[0] > 300 and image.shape[1] > 500
    assert colour_pixels(out, INIT_COLOURS["asi"]) > 300 and colour_pixels(out, INIT_COLOURS["rsi"]) > 300
    assert colour_pixels(out, INIT_COLOURS["fsi"]) == 0
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temp file left


def test_single_run_without_smoothing(runs, tmp_path):
    out = plot_learning_curves([runs / "walk_rsi"], tmp_path / "one.png", smoothing=0.0)
    assert colour_pixels(out, INIT_COLOURS["rsi"]) > 300 and colour_pixels(out, INIT_COLOURS["asi"]) == 0


def test_smoothing_is_a_bias_corrected_moving_average():
    values = np.array([1.0, 0.0, 0.0, 1.0])
    np.testing.assert_allclose(smooth(values, 0.0), values)
    out = smooth(values, 0.5)
    assert out[0] == 1.0  # no pull toward zero at the start
    np.testing.assert_allclose(out[1], (0.5 * 0.5 * 1.0) / (1 - 0.25))


@pytest.mark.parametrize(
    "setup, argv, message",
    [
        (None, ["{tmp}/nope", "--out", "{tmp}/p.png"], "not a run directory"),
        ("empty", ["{tmp}/empty", "--out", "{tmp}/p.png"], "no metrics.jsonl rows"),
        ("empty", ["{tmp}/empty", "--out", "{tmp}/p.jpg"], "must be a .png"),
        ("empty", ["{tmp}/empty", "--out", "{tmp}/x/p.png"], "does not exist"),
    ],
)
def test_bad_input_is_a_one_line_error(tmp_path, capsys, setup, argv, message):
    if setup == "empty":
        (tmp_path / "empty").mkdir()
        (tmp_path / "empty" / CONFIG_FILE).write_text("{}")
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert main(["plot", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("sfv: ") and message in err and "\n" not in err
    assert not list(tmp_path.glob("*.png")) and not list(tmp_path.glob(".*"))
