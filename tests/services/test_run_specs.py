"""Named run specs (services/specs/): each registered spec resolves to a valid config of its command
at this commit and names a results file that exists; `sfv train SPEC` starts from the spec with
flags as overrides and the run directory records the spec, what was given and the commit."""
from __future__ import annotations

import json

import pytest

from services.cli import build_parser, main
from services.commands import distill, task, train
from services.specs import RUN_SPECS, RunSpec, specs_for
from services.specs.record import RECORD_FILE
from services.training.flags import leaves, resolve
from tests.conftest import REPO


def parse(*argv: str):
    return build_parser(list(argv)).parse_args(list(argv))


def _resolve(spec: RunSpec, module_dir):
    settings = dict(spec.settings)
    if settings.get("env.action") == "latent":
        settings["env.module"] = str(module_dir)  # the user's module: a run-time argument
    flags = {path: f"spec {spec.name}" for path in settings}
    if spec.command in ("train", "pipeline"):
        return resolve(settings, flags)
    if spec.command == "task":
        base = task._default_config(settings["env.task"], settings["env.action"])
        return resolve(settings, flags, base, schema=task.task_schema())
    # a distill spec's settings go to the dataset's RecordConfig or the MotorModuleConfig, as `sfv distill` applies them
    config_settings = {k: v for k, v in settings.items() if k not in distill.SPEC_ARGUMENTS}
    resolved = []
    for schema in (distill.record_schema(), distill.module_schema()):
        paths = {leaf.path for leaf in leaves(schema.root)}
        part = {k: v for k, v in config_settings.items() if k in paths}
        resolved.append(resolve(part, {k: flags[k] for k in part}, schema=schema))
        config_settings = {k: v for k, v in config_settings.items() if k not in paths}
    assert not config_settings, f"spec {spec.name}: settings no config takes: {sorted(config_settings)}"
    return resolved[0]


def test_every_spec_resolves_at_this_commit_and_names_an_existing_results_file(tmp_path):
    assert specs_for("train")  # the catalogue registers itself
    for spec in RUN_SPECS.values():
        config = _resolve(spec, tmp_path)
        if hasattr(config, "validate"):
            config.validate()
        assert spec.report is None or (REPO / spec.report).is_file(), (spec.name, spec.report)


def test_specs_are_frozen():
    spec = specs_for("train")["walk"]
    with pytest.raises(TypeError):
        spec.settings["samples"] = 1


def test_a_spec_is_the_base_and_flags_override_it(tmp_path):
    config = train.build_config(parse("train", "cartwheel", "--out", str(tmp_path / "run"), "--samples", "3M", "--seed", "2"))
    assert (config.motion, config.samples, config.seed, config.workers) == ("deepmimic:cartwheel", 3_000_000, 2, 2)
    g1 = train.build_config(parse("train", "g1-walk", "--out", str(tmp_path / "g1")))
    assert (g1.env.character, g1.motion) == ("g1", "deepmimic:walk")


def test_an_unknown_spec_is_one_line_naming_the_ones_there_are(tmp_path, capsys):
    assert main(["train", "cartweel", "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "'cartweel'" in err and "cartwheel" in err


def test_the_run_directory_records_the_spec_the_overrides_and_the_commit(tmp_path, capsys):
    pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")
    out = tmp_path / "run"
    assert main(["train", "walk", "--out", str(out), "--samples", "64", "--batch-size", "64", "--workers", "1",
                 "--envs-per-worker", "2", "--serial", "--eval-every", "0", "--torch-threads", "1", "--quiet"]) == 0
    record = json.loads((out / RECORD_FILE).read_text())
    assert record["spec"] == "walk" and record["spec_settings"]["samples"] == 2_000_000
    assert record["given"]["samples"] == 64 and record["given"]["motion"] == "deepmimic:walk"
    assert record["git_commit"] is None or len(record["git_commit"].split("+")[0]) == 40
    assert json.loads((out / "config.json").read_text())["samples"] == 64


def test_a_distill_spec_gives_its_clips_and_settings_and_flags_win():
    args = parse("distill", "experts", "--out", "module", "--spec", "npmp-module", "--noise-std", "0.2")
    distill._spec_arguments(args)
    assert "walk_left_mirror" in args.clips and args.hold_out == ("kick", "kick_mirror")
    record = distill._config(distill.record_schema(), args)
    assert (record.steps_per_clip, record.noise_std) == (12_000, 0.2)
    given = parse("distill", "experts", "--out", "module", "--spec", "npmp-module", "--clips", "walk", "--steps-per-clip", "100")
    distill._spec_arguments(given)
    assert given.clips == ["walk"] and distill._config(distill.record_schema(), given).steps_per_clip == 100
