"""The learning suite runs the skills table by its run specs: `--skills specs` is every skill spec at
its own budget, `CLIP@spec` one clip at its spec's budget."""
from __future__ import annotations

import argparse

import pytest

from learner.errors import SfvError
from services.bench.learning_suite import add_arguments, cells, config_from_args
from services.specs import specs_for


def learning_args(skills: str):
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    args = parser.parse_args(["--out-dir", "unused", "--skills", skills, "--inits", "asi"])
    args.out, args.device, args.torch_threads, args.physics_hz = None, None, None, None
    return args


def test_specs_run_every_skill_at_its_specs_budget():
    pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")
    budgets = {cell.clip: cell.samples for cell in cells(config_from_args(learning_args("specs")))}
    specs = specs_for("train")
    assert len(budgets) == 15
    assert budgets["cartwheel"] == specs["cartwheel"].settings["samples"] == 10_000_000
    assert budgets["getup_faceup"] == specs["getup-faceup"].settings["samples"]


def test_one_clip_at_its_spec_and_a_clip_without_one_is_one_line():
    pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")
    assert [c.samples for c in cells(config_from_args(learning_args("backflip@spec,walk@1M")))] == [20_000_000, 1_000_000]
    with pytest.raises(SfvError, match="no run spec for 'laikago_walk'"):
        config_from_args(learning_args("laikago_walk@spec"))
