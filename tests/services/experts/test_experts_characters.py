"""`sfv experts --character g1`: tracking experts on the Unitree G1, one body per experts
directory, mirrored G1 experts by the G1's hinge mirror signs (`actors/character/mirror.py`),
and no G1 experts for the motor module.

The tiny G1 training needs the G1's cached model (`sfv models fetch --robot g1`) and skips
without it; the clip lists and refusals read config.json files only and run anywhere."""
from __future__ import annotations

import json

import numpy as np
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


def test_g1_clip_lists_have_mirrors_and_a_body_without_signs_is_refused():
    from actors.motion.formats.io import DEEPMIMIC_CLIPS
    from services.experts.library import MIRROR_CHARACTERS, check_mirror

    assert MIRROR_CHARACTERS == ("humanoid3d", "g1")
    assert expand_clips(["all"], "g1") == expand_clips(["all"]) == [c for clip in DEEPMIMIC_CLIPS for c in (clip, clip + "_mirror")]
    assert expand_clips(["walk", "walk_mirror", "kick_mirror"], "g1") == ["walk", "walk_mirror", "kick_mirror"]
    check_mirror("walk_mirror", "g1")
    with pytest.raises(SfvError, match="walk_mirror: mirrored experts are for humanoid3d, g1, not the atlas "
                                       r"\(it declares no hinge mirror signs\)") as exc:
        check_mirror("walk_mirror", "atlas")
    one_line(exc)


@needs_g1
def test_a_mirror_of_a_g1_expert_acts_through_the_g1_expert(tmp_path):
    """A G1 run's files (no training): `walk_mirror` is a table row and loads as the mirrored
    expert on the G1, its actions the mirror (hinges: the partner's times the sign) of the walk
    expert's on the mirrored observation."""
    from actors.character.characters import character_named
    from actors.character.mirror import action_mirror, observation_mirror
    from services.experts.library import load_expert
    from services.experts.mirrored_expert import MirroredExpert
    from services.experts.table import table_clips

    out = tmp_path / "experts"
    make_tiny_run(out / "walk", env=EnvConfig(character="g1"))
    assert table_clips(out) == ["walk", "walk_mirror"]
    g1 = character_named("g1")
    expert, mirrored = load_expert(out, "walk"), load_expert(out, "walk_mirror")
    assert isinstance(mirrored, MirroredExpert) and mirrored.motion == "deepmimic:walk_mirror"
    assert mirrored.env_config.character == "g1"
    obs = np.random.default_rng(0).normal(size=(3, 406)).astype(np.float32)
    observation_map = observation_mirror(g1.build(), 2)
    actions = mirrored.act(observation_map(obs))
    assert actions.shape == (3, g1.nu) and np.abs(actions).max() > 0.1
    np.testing.assert_allclose(actions, action_mirror("exp_map", g1)(expert.act(obs)), atol=1e-6)


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
def test_a_tiny_g1_expert_trains_and_its_table_rows_read_the_g1(tmp_path, monkeypatch):
    """walk trains on the G1; walk_mirror is not trained but acts through it, on
    `deepmimic:walk_mirror` retargeted onto the G1 at load."""
    from actors.character.characters import character_named
    from actors.character.mirror import action_mirror, state_mirror
    from services.experts import table as table_module
    from services.experts.library import load_expert
    from services.experts.mirrored_expert import MirroredExpert
    from services.training import evaluation, strict_episode

    out = tmp_path / "experts"
    summary = run_experts_job(["walk", "walk_mirror"], out, samples=2048, parallel=1, template=tiny_template(2048),
                              progress=False, character="g1")
    assert summary["character"] == "g1" and summary["status"]["walk"]["state"] == "trained"
    assert summary["status"]["walk_mirror"] == {"state": "mirrored", "of": "walk"} and not (out / "walk_mirror").exists()
    assert samples_done(out / "walk") == 2048
    config = json.loads((out / "walk" / CONFIG_FILE).read_text())
    assert config["env"]["character"] == "g1" and config["motion"] == "deepmimic:walk"
    assert json.loads((out / JOB_FILE).read_text())["character"] == "g1"
    g1 = character_named("g1")
    expert = load_expert(out, "walk", max_batch=1)
    env = expert.make_env()
    assert env.humanoid.character.name == "g1" and expert.act(env.reset(seed=0)[0][None]).shape == (1, g1.nu)
    mirrored = load_expert(out, "walk_mirror", max_batch=1)
    env_m = mirrored.make_env()  # the mirrored humanoid walk, retargeted onto the G1 at load
    assert isinstance(mirrored, MirroredExpert) and env_m.humanoid.character is g1 and env_m.motion.name == "deepmimic:walk_mirror_g1"
    # Retargeting the mirrored clip is mirroring the retargeted one, to the IK's tolerance.
    qpos_map, _ = state_mirror(env.humanoid)
    np.testing.assert_allclose(env_m.track.qpos, qpos_map(env.track.qpos), atol=1e-4)
    obs, _ = env.reset(options={"init": "rsi", "phase": 0.3})
    obs_m, _ = env_m.reset(options={"init": "rsi", "phase": 0.3})
    action, action_m = expert.act(obs[None]), mirrored.act(obs_m[None])
    assert action_m.shape == (1, g1.nu) and np.abs(action).max() > 0.01
    np.testing.assert_allclose(action_m, action_mirror("exp_map", g1)(action), atol=1e-3)

    seen = []  # what the table's tracking curve compares: the G1's layout, not the humanoid's default
    original = evaluation.tracking_errors

    def spy(sim, ref):
        seen.append((sim.hinges.shape[1], sim.end_effectors.shape[1], ref.hinges.shape[1], ref.end_effectors.shape[1]))
        return original(sim, ref)

    monkeypatch.setattr(evaluation, "tracking_errors", spy)  # the table's curve
    monkeypatch.setattr(strict_episode, "tracking_errors", spy)  # its evaluations' episodes
    table = table_module.build_table(out, episodes=1, starts=2, curve_seconds=0.3, progress=False)
    assert [row["clip"] for row in table["experts"]] == ["walk", "walk_mirror"]  # the G1's mirror by symmetry
    for row in table["experts"]:
        assert row["character"] == "g1" and row["samples"] == 2048 and 0.0 <= row["normalized_return"] <= 1.0
        assert row["joint_rotation_error_rad"] > 0.0 and row["end_effector_error_m"] > 0.0
        assert all(v > 0.0 for v in row["curve"]["end_effector_error_m"])
    assert table["experts"][1]["mirror_of"] == "walk" and table["experts"][1]["motion"] == "deepmimic:walk_mirror"
    hinges, effectors = g1.nu, len(g1.end_effector_links)
    assert len(seen) >= 6 and set(seen) == {(hinges, effectors, hinges, effectors)}  # 29 hinges, 4 end effectors
    assert "Experts (g1)" in (out / table_module.TABLE_MD).read_text()

    # Resumed or extended as the humanoid's: one line naming the flag and the directory.
    with pytest.raises(SfvError, match=f"{out} holds g1 experts \\(walk/\\), not humanoid3d: rerun with --character g1"):
        run_experts_job(["walk"], out, samples=512, parallel=1, template=tiny_template(512), progress=False)
