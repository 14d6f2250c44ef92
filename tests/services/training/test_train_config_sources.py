"""`sfv train`'s settings from one place: flags generated from the config fields, YAML config
files, `--print-config`, and which settings `--resume` lets change."""
from __future__ import annotations

import argparse
import dataclasses
import json

import pytest

from learner.errors import SfvError
from services.cli import main
from services.commands import train
from services.training.config import TrainConfig
from services.training.flags import leaves


def parse(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    train.register(parser.add_subparsers())
    return parser.parse_args(["train", *argv])


def _plain(config: TrainConfig) -> dict:
    return json.loads(json.dumps(config.to_dict()))


def test_every_field_has_a_flag_and_no_flag_changes_the_dataclass_defaults(tmp_path):
    help_text = " ".join(train_help().split())
    for leaf in leaves():
        if leaf.path != "out":
            assert leaf.flag in help_text, leaf.path
    config = train.build_config(parse("--out", str(tmp_path / "run")))
    assert _plain(config) == {**_plain(TrainConfig()), "out": str(tmp_path / "run")}


def train_help() -> str:
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers()
    train.register(sub)
    return sub.choices["train"].format_help()


def test_long_and_short_flags_reach_nested_fields(tmp_path):
    config = train.build_config(parse("--out", str(tmp_path), "--env.physics.friction", "0.7", "--physics-hz", "600",
                                      "--ppo.value-lr", "3e-4", "--hidden", "64,32", "--no-env.zero-reward-on-fall",
                                      "--reference-obs", "none", "--ppo.target-kl", "none", "--reward", "sfv_paper",
                                      "--env.sfv.reward.com-weight", "0.3"))
    assert (config.env.physics.friction, config.env.physics.physics_hz) == (0.7, 600.0)
    assert config.ppo.value_lr == 3e-4 and config.ppo.policy_hidden == config.ppo.value_hidden == (64, 32)
    assert config.env.zero_reward_on_fall is False and config.env.reference_obs_steps == () and config.ppo.target_kl is None
    # The preset sets the paper's weights; a field given explicitly wins over the preset.
    assert (config.env.sfv.reward.form, config.env.sfv.reward.pose_weight, config.env.sfv.reward.com_weight) == ("sfv_paper", 0.65, 0.3)


def test_print_config_round_trips_through_a_config_file_and_flags_win_over_it(tmp_path, capsys):
    assert main(["train", "--print-config", "--out", str(tmp_path / "a"), "--epochs", "3", "--ground-contact", "left_wrist",
                 "--env.horizon-s", "5"]) == 0
    written = capsys.readouterr().out
    path = tmp_path / "run.yaml"
    path.write_text(written)
    from_file = train.build_config(parse("--config", str(path)))
    assert from_file.ppo.update_epochs == 3 and from_file.env.ground_contact_links == ("left_wrist",)
    assert from_file.env.horizon_s == 5.0 and from_file.out == str(tmp_path / "a")
    overridden = train.build_config(parse("--config", str(path), "--epochs", "2", "--out", str(tmp_path / "b")))
    assert overridden.ppo.update_epochs == 2 and overridden.out == str(tmp_path / "b")
    assert dataclasses.replace(overridden, out=from_file.out).ppo.policy_hidden == from_file.ppo.policy_hidden
    assert not (tmp_path / "a").exists()  # printing the config writes nothing


def test_a_runs_config_json_given_back_as_a_config_file_reads_its_exponent_floats(tmp_path):
    """A run's config.json writes 5e-05 (json.dumps); YAML 1.1 would read it as a string."""
    written = tmp_path / "config.json"
    written.write_text(json.dumps({"ppo": {"policy_lr": 5e-05, "value_lr": 1e-3}, "samples": 2000000,
                                   "out": str(tmp_path / "other"), "job_id": "train-other"}))
    assert '"policy_lr": 5e-05' in written.read_text()
    config = train.build_config(parse("--config", str(written), "--out", str(tmp_path / "run")))
    assert (config.ppo.policy_lr, config.ppo.value_lr, config.samples) == (5e-05, 1e-3, 2000000)
    # The other run's ASI job id is not taken over; given with its own --out it is kept.
    assert config.job_id is None
    assert train.build_config(parse("--config", str(written))).job_id == "train-other"


@pytest.mark.parametrize("text, fault", [
    ("workers: 2\nenv:\n  horizn_s: 3\n", "unknown setting 'env.horizn_s'"),
    ("workers: two\n", "workers must be int"),
    ("env:\n  state_space: quats\n", "env.state_space must be one of rotvec, qpos"),
    ("- a list\n", "holds a mapping"),
    ("ppo: {policy_hidden: [64, x]}\n", "ppo.policy_hidden must be a list of int"),
])
def test_bad_config_files_are_one_line_errors_naming_file_and_setting(tmp_path, capsys, text, fault):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    assert main(["train", "--config", str(path), "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and str(path) in err and fault in err
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("flags, fault", [
    (["--physics-hz", "100"], "--physics-hz must be a positive whole multiple of the 30 Hz control rate"),
    (["--physics-hz", "0"], "--physics-hz"),
    (["--env.control-hz", "0"], "--env.control-hz must be positive"),
    (["--action", "axis_angle"], "--action axis_angle needs --residual-scale 0"),
    (["--env.physics.friction", "-1"], "--env.physics.friction must be >= 0"),
])
def test_bad_values_fail_before_the_run_directory_is_written(tmp_path, capsys, flags, fault):
    run = tmp_path / "run"
    assert main(["train", "--out", str(run), *flags]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and fault in err
    assert not run.exists()


def _saved_run(tmp_path, *flags):
    run = tmp_path / "run"
    run.mkdir()
    config = train.build_config(parse("--out", str(run), *flags))
    (run / "config.json").write_text(json.dumps(config.to_dict()))
    return run


def test_resume_keeps_the_saved_config_and_lets_safe_settings_change(tmp_path):
    run = _saved_run(tmp_path, "--samples", "1000", "--hidden", "64,64", "--epochs", "2", "--physics-hz", "600")
    kept = train.build_config(parse("--out", str(run), "--resume"))
    assert (kept.samples, kept.ppo.policy_hidden, kept.ppo.update_epochs, kept.env.physics.physics_hz) == (1000, (64, 64), 2, 600.0)
    changed = train.build_config(parse("--out", str(run), "--resume", "--samples", "5000", "--policy-lr", "1e-4",
                                       "--epochs", "3", "--workers", "4", "--torch-threads", "1", "--hidden", "64,64"))
    assert (changed.samples, changed.ppo.policy_lr, changed.ppo.update_epochs, changed.workers, changed.torch_threads) == \
        (5000, 1e-4, 3, 4, 1)
    assert changed.ppo.policy_hidden == (64, 64)  # an unsafe setting given with its saved value is fine


def test_asi_fall_weighting_is_a_flag_validated_and_safe_on_resume(tmp_path):
    run = _saved_run(tmp_path)
    saved = json.loads((run / "config.json").read_text())
    assert saved.pop("asi_fall_weighting") == 0.0  # off by default
    (run / "config.json").write_text(json.dumps(saved))  # a run from before the option
    assert TrainConfig.from_dict(saved).asi_fall_weighting == 0.0
    resumed = train.build_config(parse("--out", str(run), "--resume", "--asi-fall-weighting", "0.5"))
    assert resumed.asi_fall_weighting == 0.5
    bad = train.build_config(parse("--out", str(tmp_path / "bad"), "--asi-fall-weighting", "1.5"))
    with pytest.raises(SfvError, match=r"--asi-fall-weighting must lie in \[0, 1\], got 1.5"):
        bad.validate()


@pytest.mark.parametrize("flags, named", [
    (["--hidden", "128,128"], "--hidden"),
    (["--physics-hz", "1200"], "--physics-hz"),
    (["--action", "axis_angle", "--residual-scale", "0"], "--action"),
    (["--env.sfv.reward.pose-scale", "3"], "--env.sfv.reward.pose-scale"),
    (["--motion", "deepmimic:run"], "--motion"),
])
def test_resume_refuses_unsafe_changes_naming_the_flag(tmp_path, capsys, flags, named):
    run = _saved_run(tmp_path, "--hidden", "64,64")
    before = (run / "config.json").read_text()
    assert main(["train", "--out", str(run), "--resume", *flags]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"sfv: {named}: cannot change on --resume") and err.count("\n") == 0
    assert (run / "config.json").read_text() == before


def test_out_is_required_to_train():
    with pytest.raises(SfvError, match="--out is required"):
        train.build_config(parse())


def test_runner_flags_agree_with_the_older_serial_switch(tmp_path):
    assert train.build_config(parse("--out", str(tmp_path), "--serial")).runner == "in_process"
    processes = train.build_config(parse("--out", str(tmp_path), "--runner", "processes"))
    assert (processes.runner, processes.serial) == ("processes", False)
    run = _saved_run(tmp_path, "--serial")
    resumed = train.build_config(parse("--out", str(run), "--resume", "--runner", "ray"))
    assert (resumed.runner, resumed.serial) == ("ray", False)


def test_a_run_config_written_with_the_serial_switch_loads_as_the_in_process_runner():
    old = {**TrainConfig().to_dict(), "serial": True}
    del old["runner"]
    assert TrainConfig.from_dict(old).runner == "in_process"
    assert TrainConfig.from_dict({**TrainConfig().to_dict(), "serial": False}).runner == "ray"

