"""`sfv experts --character g1`: tracking experts on the Unitree G1, one body per experts
directory, no mirrored G1 experts, and no G1 experts for the motor module.

The tiny G1 training needs the G1's cached model (`sfv models fetch --robot g1`) and skips
without it; the refusals read config.json files only and run anywhere."""
from __future__ import annotations

import json

import pytest

from actors.character import g1_model
from actors.envs.imitation_env import EnvConfig
from learner.errors import SfvError
from services.experts.job import JOB_FILE, expand_clips, run_experts_job, samples_done
from services.training.run_dir import CONFIG_FILE
from tests.services.experts.test_experts_job import tiny_template
from tests.services.export.test_export_onnx import make_tiny_run

pytest.importorskip("pybullet_data", reason="the experts train on the DeepMimic clips of pybullet_data")
needs_g1 = pytest.mark.skipif(not g1_model.model_available(), reason="G1 model not cached (sfv models fetch --robot g1)")


def one_line(exc: pytest.ExceptionInfo) -> str:
    text = str(exc.value)
    assert "\n" not in text
    return text


def test_mirrored_g1_experts_are_refused_and_all_has_no_mirrors(tmp_path, capsys):
    from actors.motion.formats.io import DEEPMIMIC_CLIPS
    from services.cli import main

    assert expand_clips(["all"], "g1") == list(DEEPMIMIC_CLIPS)
    assert expand_clips(["walk"], "g1") == ["walk"]
    with pytest.raises(SfvError, match="walk_mirror: mirrored experts are humanoid3d-only for now, not the g1's") as exc:
        expand_clips(["walk", "walk_mirror"], "g1")
    one_line(exc)
    out = tmp_path / "experts"
    with pytest.raises(SfvError, match="kick_mirror: mirrored experts are humanoid3d-only"):
        run_experts_job(["kick_mirror"], out, samples=128, parallel=1, template=tiny_template(128), progress=False, character="g1")
    assert not out.exists()  # refused before anything is written
    assert main(["experts", "run_mirror", "--character", "g1", "--out", str(out)]) == 2
    assert "run_mirror: mirrored experts are humanoid3d-only for now" in capsys.readouterr().err
    assert not out.exists()


def test_a_mirror_of_a_g1_expert_is_refused_where_experts_are_loaded(tmp_path):
    from services.experts.library import load_expert
    from services.experts.table import build_table, table_clips

    out = tmp_path / "experts"
    make_tiny_run(out / "walk", env=EnvConfig(character="g1"))  # a G1 run's files, no training
    assert table_clips(out) == ["walk"]  # no walk_mirror row for the G1
    with pytest.raises(SfvError, match="walk_mirror: mirrored experts are humanoid3d-only for now, not the g1's") as exc:
        load_expert(out, "walk_mirror")
    one_line(exc)
    with pytest.raises(SfvError, match="walk_mirror: mirrored experts are humanoid3d-only"):
        build_table(out, clips=["walk", "walk_mirror"], episodes=1, starts=1, curve_seconds=0.1, progress=False)


@pytest.mark.parametrize("trained, asked", [("humanoid3d", "g1"), ("g1", "humanoid3d")])
def test_a_directory_of_one_body_is_not_extended_or_resumed_with_the_other(tmp_path, capsys, trained, asked):
    from services.cli import main

    out = tmp_path / "experts"
    make_tiny_run(out / "walk", env=EnvConfig(character=trained))  # a finished walk expert (4096 samples) of one body
    expected = f"sfv experts: {out} holds {trained} experts (walk/), not {asked}: rerun with --character {trained}"
    for clips in (["walk"], ["punch"]):  # resuming its clip, or adding another one
        with pytest.raises(SfvError, match=expected.replace("(", r"\(").replace(")", r"\)")) as exc:
            run_experts_job(clips, out, samples=128, parallel=1, template=tiny_template(128), progress=False, character=asked)
        one_line(exc)
    assert not (out / "punch").exists() and not (out / JOB_FILE).exists()
    assert main(["experts", "walk", "--out", str(out), "--character", asked, "--quiet"]) == 2
    assert expected in capsys.readouterr().err
    # The same body is fine: the finished expert is skipped.
    assert run_experts_job(["walk"], out, samples=128, parallel=1, template=tiny_template(128), progress=False,
                           character=trained)["status"]["walk"]["state"] == "finished"


def test_the_motor_module_refuses_g1_experts(tmp_path, capsys):
    from services.cli import main
    from services.motor.recorder import expert_clips

    out = tmp_path / "experts"
    make_tiny_run(out / "walk", env=EnvConfig(character="g1"))
    with pytest.raises(SfvError, match="a g1 expert; the motor module .* distils humanoid3d experts only for now") as exc:
        expert_clips(out, None)
    one_line(exc)
    assert main(["distill", str(out), "--out", str(tmp_path / "module"), "--quiet"]) == 2
    assert "distils humanoid3d experts only for now" in capsys.readouterr().err
    assert not (tmp_path / "module").exists()


@needs_g1
def test_a_tiny_g1_expert_trains_and_its_table_row_reads_the_g1(tmp_path, monkeypatch):
    from actors.character.characters import character_named
    from services.experts import table as table_module
    from services.experts.library import load_expert
    from services.training import evaluation

    out = tmp_path / "experts"
    summary = run_experts_job(["walk"], out, samples=2048, parallel=1, template=tiny_template(2048), progress=False, character="g1")
    assert summary["character"] == "g1" and summary["status"]["walk"]["state"] == "trained"
    assert samples_done(out / "walk") == 2048
    config = json.loads((out / "walk" / CONFIG_FILE).read_text())
    assert config["env"]["character"] == "g1" and config["motion"] == "deepmimic:walk"
    assert json.loads((out / JOB_FILE).read_text())["character"] == "g1"
    g1 = character_named("g1")
    expert = load_expert(out, "walk", max_batch=1)
    env = expert.make_env()
    assert env.humanoid.character.name == "g1" and expert.act(env.reset(seed=0)[0][None]).shape == (1, g1.nu)

    seen = []  # what the table's tracking curve compares: the G1's layout, not the humanoid's default
    original = evaluation.tracking_errors

    def spy(sim, ref):
        seen.append((sim.hinges.shape[1], sim.end_effectors.shape[1], ref.hinges.shape[1], ref.end_effectors.shape[1]))
        return original(sim, ref)

    monkeypatch.setattr(evaluation, "tracking_errors", spy)
    table = table_module.build_table(out, episodes=1, starts=2, curve_seconds=0.3, progress=False)
    assert [row["clip"] for row in table["experts"]] == ["walk"]  # no mirror for the G1
    row = table["experts"][0]
    assert row["character"] == "g1" and row["samples"] == 2048 and 0.0 <= row["normalized_return"] <= 1.0
    assert row["joint_rotation_error_rad"] > 0.0 and row["end_effector_error_m"] > 0.0
    assert all(v > 0.0 for v in row["curve"]["end_effector_error_m"])
    hinges, effectors = g1.nu, len(g1.end_effector_links)
    assert len(seen) >= 3 and set(seen) == {(hinges, effectors, hinges, effectors)}  # 29 hinges, 4 end effectors
    assert "Experts (g1)" in (out / table_module.TABLE_MD).read_text()

    # Resumed or extended as the humanoid's: one line naming the flag and the directory.
    with pytest.raises(SfvError, match=f"{out} holds g1 experts \\(walk/\\), not humanoid3d: rerun with --character g1"):
        run_experts_job(["walk"], out, samples=512, parallel=1, template=tiny_template(512), progress=False)
