"""The learning curve with periodic evaluations (`eval/...` metrics rows), decoded back as pixels."""
from __future__ import annotations

import json

import imageio.v2 as imageio
import numpy as np

from services.cli import main
from services.training.curves import INIT_COLOURS, eval_curve, plot_learning_curves
from services.training.run_dir import CONFIG_FILE, METRICS_FILE


def make_run(path, init: str, evaluations: bool) -> None:
    path.mkdir(parents=True)
    (path / CONFIG_FILE).write_text(json.dumps({"init": init, "motion": "deepmimic:walk"}))
    rows = []
    for k, r in enumerate(np.linspace(0.05, 0.8, 40)):
        row = {"samples": 4096 * (k + 1), "normalized_return": float(r)}
        if evaluations and k % 5 == 4:
            row.update({"eval/normalized_return": float(r) * 0.8, "eval/fall_rate": 1.0 - k / 40, "eval/episodes": 8})
        rows.append(row)
    (path / METRICS_FILE).write_text("".join(json.dumps(row) + "\n" for row in rows))


def colour_mask(png, name: str) -> np.ndarray:
    from matplotlib.colors import to_rgb

    target = np.array(to_rgb(name)) * 255
    image = imageio.imread(png)[..., :3].astype(float)
    return np.abs(image - target).max(axis=-1) < 12


def test_eval_curve_reads_only_the_evaluated_iterations(tmp_path):
    make_run(tmp_path / "run", "asi", evaluations=True)
    samples, returns, falls = eval_curve(tmp_path / "run")
    assert len(samples) == 8 and samples[0] == 4096 * 5
    np.testing.assert_allclose(falls, [1.0 - k / 40 for k in range(4, 40, 5)])
    assert len(eval_curve(tmp_path / "missing")[0]) == 0


def test_evaluations_add_a_fall_rate_panel_in_the_run_colour(tmp_path, capsys):
    make_run(tmp_path / "with", "asi", evaluations=True)
    make_run(tmp_path / "without", "rsi", evaluations=False)
    plain = plot_learning_curves([tmp_path / "without"], tmp_path / "plain.png")
    both = tmp_path / "both.png"
    assert main(["plot", str(tmp_path / "with"), str(tmp_path / "without"), "--out", str(both)]) == 0
    capsys.readouterr()
    plain_image, both_image = imageio.imread(plain), imageio.imread(both)
    assert both_image.shape[0] > plain_image.shape[0]  # a second panel
    asi = colour_mask(both, INIT_COLOURS["asi"])
    rsi = colour_mask(both, INIT_COLOURS["rsi"])
    lower = both_image.shape[0] * 3 // 4  # the fall-rate panel lies in the bottom quarter
    assert asi[lower:].sum() > 50  # the evaluated run's fall rate
    assert rsi[lower:].sum() == 0  # the run without evaluations has none
    assert asi[:lower].sum() > 300 and rsi[:lower].sum() > 300  # both training curves above
    # Without evaluations the figure is the single panel it always was.
    assert colour_mask(plain, INIT_COLOURS["asi"]).sum() == 0
