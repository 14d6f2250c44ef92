"""One configuration mechanism for every command (services/training/flags.py's ConfigSchema):
`sfv task` and `sfv distill` get their flags, YAML and resume rules from their config dataclasses."""
from __future__ import annotations

import json

import pytest

from learner.errors import SfvError
from services.cli import build_parser
from services.commands import distill, task


def parse(*argv: str):
    return build_parser(list(argv)).parse_args(list(argv))


def test_task_flags_are_its_config_fields_with_the_old_short_names(tmp_path):
    config = task.build_config(parse("task", "push-box", "--out", str(tmp_path / "run"), "--action", "joint",
                                     "--latent-scale", "2", "--env.success-radius", "0.3", "--batch-size", "1024"))
    assert (config.env.task, config.env.action, config.env.latent_scale, config.env.success_radius) == ("push_box", "joint", 2.0, 0.3)
    assert config.ppo.batch_size == 1024 and config.ppo.action_std == 0.1  # the joint space's PPO settings


def test_task_settings_come_from_a_yaml_file_and_flags_win(tmp_path):
    path = tmp_path / "task.yaml"
    path.write_text("samples: 5000\nenv:\n  horizon_s: 4.0\n")
    config = task.build_config(parse("task", "go-to", "--out", str(tmp_path / "run"), "--config", str(path), "--samples", "7000"))
    assert (config.samples, config.env.horizon_s) == (7000, 4.0)
    path.write_text("env:\n  horizon: 4.0\n")
    with pytest.raises(SfvError, match="unknown setting 'env.horizon'"):
        task.build_config(parse("task", "go-to", "--out", str(tmp_path / "run"), "--config", str(path)))


def test_task_resume_keeps_safe_changes_and_refuses_the_rest_naming_the_flag(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    (run / "config.json").write_text(json.dumps(task.build_config(parse("task", "go-to", "--out", str(run))).to_dict()))
    resumed = task.build_config(parse("task", "go-to", "--out", str(run), "--resume", "--samples", "2M"))
    assert resumed.samples == 2_000_000 and resumed.env.task == "go_to"
    with pytest.raises(SfvError, match="--horizon-s: cannot change on --resume"):
        task.build_config(parse("task", "go-to", "--out", str(run), "--resume", "--horizon-s", "3"))
    with pytest.raises(SfvError, match=r"the task \(push-box\): cannot change on --resume"):
        task.build_config(parse("task", "push-box", "--out", str(run), "--resume"))


def test_distill_list_settings_take_words_or_commas():
    for words in (["16", "32"], ["16,32"]):
        args = parse("distill", "experts", "--out", "m", "--encoder-hidden", *words, "--steps-per-clip", "2k")
        assert distill._config(distill.module_schema(), args).encoder_hidden == (16, 32)
        assert distill._config(distill.record_schema(), args).steps_per_clip == 2000


def test_a_task_spec_is_the_base_and_flags_override_it(tmp_path):
    config = task.build_config(parse("task", "npmp-push-box-joint", "--out", str(tmp_path / "run"), "--samples", "1000"))
    assert (config.env.task, config.env.action, config.samples, config.envs_per_worker) == ("push_box", "joint", 1000, 16)


def test_every_setting_has_a_short_help_and_its_measurements_live_in_the_docs():
    """A help text says what a setting does in one line; the numbers behind its default go to docs/."""
    from services.training.flags import leaves, train_schema

    for schema in (train_schema(), task.task_schema(), distill.record_schema(), distill.module_schema()):
        for leaf in leaves(schema.root):
            if leaf.path not in schema.skipped:
                assert leaf.help and len(leaf.help) <= 320, (schema.command, leaf.path, len(leaf.help))
