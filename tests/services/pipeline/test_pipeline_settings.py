"""`sfv pipeline`'s training settings: sfv train's, with the static pipeline's own budget."""
from __future__ import annotations

import argparse

import pytest

from services.commands import pipeline
from services.commands._pipeline_settings import STATIC_DEFAULTS, train_config
from services.training.config import TrainConfig


def _args(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers()
    pipeline.register(sub)
    return parser.parse_args(["pipeline", "clip.mp4", "--out", "o", *argv])


def test_the_static_pipeline_trains_longer_than_sfv_trains_quick_default_unless_told(tmp_path):
    assert STATIC_DEFAULTS["samples"] > TrainConfig().samples
    default = train_config(_args([]), "m.npz", str(tmp_path / "t"), STATIC_DEFAULTS)
    assert default.samples == STATIC_DEFAULTS["samples"]
    assert default.first_frame_share == STATIC_DEFAULTS["first_frame_share"] > TrainConfig().first_frame_share
    assert train_config(_args(["--samples", "300k"]), "m.npz", str(tmp_path / "t"), STATIC_DEFAULTS).samples == 300_000
    config = tmp_path / "c.yaml"
    config.write_text("samples: 400000\n")
    from_file = train_config(_args(["--config", str(config)]), "m.npz", str(tmp_path / "t"), STATIC_DEFAULTS)
    assert from_file.samples == 400_000
    windows = train_config(_args([]), "", "", None)  # the moving path's windows
    assert (windows.samples, windows.first_frame_share) == (TrainConfig().samples, TrainConfig().first_frame_share)


def test_the_help_shows_the_pipelines_own_default(capsys):
    with pytest.raises(SystemExit):
        _args(["--help"])
    assert f"default: {STATIC_DEFAULTS['samples']} with a static camera" in " ".join(capsys.readouterr().out.split())


def test_the_person_flags_reach_the_static_pipeline_and_bad_ones_are_one_line(tmp_path, capsys):
    from services.cli import main

    args = _args(["--person", "1", "--frames", "10:60"])
    assert (args.person, args.person_at, args.frames) == (1, None, "10:60")
    video = tmp_path / "clip.mp4"
    video.write_bytes(b"")
    for flags, message in ((["--camera", "moving", "--person", "1"], "--person is for --camera static"),
                           (["--person", "-1"], "--person must be >= 0, got -1"),
                           (["--person", "0", "--person-at", "1,2@3"], "--person and --person-at exclude each other"),
                           (["--frames", "9:3"], "--frames '9:3': the end must come after the start")):
        assert main(["pipeline", str(video), "--out", str(tmp_path / "o"), *flags]) == 2
        assert message in capsys.readouterr().err
    assert not (tmp_path / "o").exists()  # nothing written before the flags were checked
