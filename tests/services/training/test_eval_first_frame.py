"""`sfv eval` on a clip that does not loop: the first-frame episode beside the phase average."""
from __future__ import annotations

import json

import pytest

from services.cli import main
from tests.services.training.test_evaluate_strict import kneel_action, stand_motion
from tests.stand_run import write_stand_run


def _run(root, loop: bool, edit):
    return write_stand_run(root, stand_motion(seconds=2.0, loop=loop, name="stand"), edit)


def _hold(policy):  # zero residual: the character holds the reference
    policy.mean_net[-1].weight.zero_()
    policy.mean_net[-1].bias.zero_()


def _kneel(policy):
    """A constant action: absolute PD targets with both knees fully bent (the character drops)."""
    import torch

    from actors.envs.imitation_env import EnvConfig

    policy.mean_net[-1].weight.zero_()
    policy.mean_net[-1].bias.copy_(torch.as_tensor(kneel_action(EnvConfig(residual_action_scale=None))))


def _absolute_targets(run):
    from services.training.run_dir import CONFIG_FILE

    config = json.loads((run / CONFIG_FILE).read_text())
    config["env"]["residual_action_scale"] = None
    (run / CONFIG_FILE).write_text(json.dumps(config))


def test_a_clip_that_does_not_loop_reports_its_first_frame_episode(tmp_path, capsys):
    run = _run(tmp_path, loop=False, edit=_hold)
    assert main(["eval", str(run), "--episodes", "2"]) == 0
    captured = capsys.readouterr()
    result = json.loads(captured.out)
    first = result["first_frame"]
    assert first["fell"] is False and first["clip_seconds"] == pytest.approx(2.0)
    assert first["episode_seconds"] == pytest.approx(first["clip_seconds"]) and first["normalized_return"] > 0.9
    assert captured.err.strip().startswith("from the first frame: upright to the end (2.00 s)")
    assert "\n" not in captured.err.strip() and "from 2 evenly spaced phases" in captured.err


def test_a_controller_that_falls_from_the_first_frame_says_when(tmp_path, capsys):
    run = _run(tmp_path, loop=False, edit=_kneel)
    _absolute_targets(run)
    assert main(["eval", str(run), "--episodes", "2"]) == 0
    captured = capsys.readouterr()
    first = json.loads(captured.out)["first_frame"]
    assert first["fell"] is True and first["episode_seconds"] < 1.0 and first["clip_seconds"] == pytest.approx(2.0)
    assert f"fell at {first['episode_seconds']:.2f} s of 2.00 s" in captured.err


def test_a_looping_clip_has_no_first_frame_episode(tmp_path, capsys):
    run = _run(tmp_path, loop=True, edit=_hold)
    assert main(["eval", str(run), "--episodes", "2"]) == 0
    captured = capsys.readouterr()
    assert "first_frame" not in json.loads(captured.out) and captured.err == ""
