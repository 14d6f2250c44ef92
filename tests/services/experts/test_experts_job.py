"""`sfv experts`: the resumable job over a clip list and the expert table, on tiny budgets."""
from __future__ import annotations

import json
import math

import pytest

from learner.errors import SfvError
from services.experts.job import JOB_FILE, expand_clips, job_template, run_experts_job, samples_done
from services.training.run_dir import CONFIG_FILE, read_metrics

pytest.importorskip("pybullet_data", reason="the experts train on the DeepMimic clips of pybullet_data")


def tiny_template(samples: int):
    config = job_template(samples)
    config.workers, config.envs_per_worker, config.init = 1, 4, "rsi"
    config.eval_every, config.plot_every, config.checkpoint_every = 0, 0, 1
    config.env = type(config.env)(horizon_s=1.0)
    config.ppo.batch_size = config.ppo.minibatch_size = 128
    config.ppo.policy_hidden, config.ppo.value_hidden = (16,), (16,)
    return config


def test_clip_lists():
    assert expand_clips(["walk_mirror", "walk", "walk"]) == ["walk_mirror", "walk"]
    everything = expand_clips(["all"])
    assert len(everything) == 30 and "cartwheel_mirror" in everything
    with pytest.raises(SfvError, match="'wlak' is not a DeepMimic clip"):
        expand_clips(["wlak"])


def test_job_trains_skips_finished_and_resumes_partial(tmp_path):
    out = tmp_path / "experts"
    summary = run_experts_job(["kick_mirror"], out, samples=128, parallel=1, template=tiny_template(128), progress=False)
    kick = summary["status"]["kick"]
    assert (kick["state"], kick["from_samples"], kick["samples"]) == ("trained", 0, 128)
    assert summary["status"]["kick_mirror"] == {"state": "mirrored", "of": "kick"}
    assert json.loads((out / "kick" / CONFIG_FILE).read_text())["motion"] == "deepmimic:kick"
    assert json.loads((out / JOB_FILE).read_text())["status"]["kick"]["state"] == "trained"
    metrics_before = (out / "kick" / "metrics.jsonl").read_text()

    again = run_experts_job(["kick"], out, samples=128, parallel=1, template=tiny_template(128), progress=False)
    assert again["status"]["kick"] == {"state": "finished", "samples": 128, "run": str(out / "kick")}
    assert (out / "kick" / "metrics.jsonl").read_text() == metrics_before  # nothing trained

    more = run_experts_job(["kick"], out, samples=256, parallel=1, template=tiny_template(256), progress=False)
    assert more["status"]["kick"]["state"] == "trained" and more["status"]["kick"]["from_samples"] == 128
    assert [row["samples"] for row in read_metrics(out / "kick")] == [128, 256]  # continued, not restarted
    assert samples_done(out / "kick") == 256


def test_job_refuses_a_run_directory_of_another_clip(tmp_path):
    out = tmp_path / "experts"
    run_experts_job(["kick"], out, samples=128, parallel=1, template=tiny_template(128), progress=False)
    (out / "kick").rename(out / "punch")
    with pytest.raises(SfvError, match="trains deepmimic:kick, not deepmimic:punch"):
        run_experts_job(["punch"], out, samples=256, parallel=1, template=tiny_template(256), progress=False)


def test_a_motion_file_is_a_clip_named_by_its_stem(tmp_path):
    from actors.motion.bend import bend_motion
    from actors.motion.formats.io import load_motion, save_motion

    clip = tmp_path / "walk_turn45.npz"
    save_motion(bend_motion(load_motion("deepmimic:walk"), yaw_rate=math.radians(45.0), seconds=2.0, name="walk_turn45"), clip)
    assert expand_clips([str(clip), "walk_turn45_mirror", "kick"]) == ["walk_turn45", "walk_turn45_mirror", "kick"]
    with pytest.raises(SfvError, match="no such motion file"):
        expand_clips([str(tmp_path / "missing.npz")])
    out = tmp_path / "experts"
    summary = run_experts_job([str(clip)], out, samples=128, parallel=1, template=tiny_template(128), progress=False)
    assert summary["status"]["walk_turn45"]["state"] == "trained"
    assert json.loads((out / "walk_turn45" / CONFIG_FILE).read_text())["motion"] == str(clip.resolve())
    # Later commands name it by its run directory (resume, table), and its mirror is served by symmetry.
    assert run_experts_job(["walk_turn45"], out, samples=128, parallel=1, template=tiny_template(128),
                           progress=False)["status"]["walk_turn45"]["state"] == "finished"
    from services.experts.library import load_expert

    mirrored = load_expert(out, "walk_turn45_mirror", max_batch=1)
    assert mirrored.motion == str(clip.resolve()) + "_mirror" and mirrored.make_env() is not None


def test_table_of_a_tiny_expert_and_its_mirror(tmp_path):
    from services.experts.table import TABLE_JSON, TABLE_MD, TABLE_PNG, build_table

    out = tmp_path / "experts"
    run_experts_job(["jump"], out, samples=128, parallel=1, template=tiny_template(128), progress=False)
    table = build_table(out, episodes=2, starts=3, curve_seconds=0.5, progress=False)
    rows = {row["clip"]: row for row in table["experts"]}
    assert list(rows) == ["jump", "jump_mirror"]
    for row in rows.values():
        assert 0.0 <= row["normalized_return"] <= 1.0 and row["episodes"] == 2 and row["samples"] == 128
        assert row["joint_rotation_error_rad"] > 0.0 and row["end_effector_error_m"] > 0.0
        curve = row["curve"]
        assert len(curve["seconds"]) == 15 and curve["rollouts"][0] == 3
        assert all(0.0 <= f <= 1.0 for f in curve["fallen_fraction"])
    # The mirrored expert is the same controller reflected: the figures agree up to MuJoCo's asymmetries.
    assert rows["jump_mirror"]["mirror_of"] == "jump"
    assert abs(rows["jump_mirror"]["normalized_return_gap"]) < 0.05
    assert json.loads((out / TABLE_JSON).read_text())["experts"][1]["clip"] == "jump_mirror"
    assert "| jump_mirror |" in (out / TABLE_MD).read_text()
    assert (out / TABLE_PNG).read_bytes()[:4] == b"\x89PNG"
    # Built again: the rows of experts that did not train since are kept, the others measured anew.
    assert build_table(out, episodes=2, starts=3, curve_seconds=0.5, progress=False)["reused"] == ["jump", "jump_mirror"]
    run_experts_job(["jump"], out, samples=256, parallel=1, template=tiny_template(256), progress=False)
    table = build_table(out, episodes=2, starts=3, curve_seconds=0.5, progress=False)
    assert table["reused"] == [] and {row["samples"] for row in table["experts"]} == {256}
    build_table(out, clips=["jump"], episodes=2, starts=3, curve_seconds=0.5, progress=False, out=tmp_path / "table")
    assert (tmp_path / "table" / TABLE_MD).is_file()


@pytest.mark.slow
def test_job_runs_its_trainings_as_ray_tasks(tmp_path):
    """parallel > 1: one Ray task per training, both finished, each a standard run directory."""
    out = tmp_path / "experts"
    summary = run_experts_job(["kick", "punch"], out, samples=128, parallel=2, template=tiny_template(128), progress=False)
    for clip in ("kick", "punch"):
        assert summary["status"][clip]["state"] == "trained"
        assert samples_done(out / clip) == 128
        assert [row["samples"] for row in read_metrics(out / clip)] == [128]


def test_cli_names_a_bad_clip_and_a_missing_directory(tmp_path, capsys):
    from services.cli import main

    assert main(["experts", "wlak", "--out", str(tmp_path / "x")]) == 2
    assert "'wlak' is not a DeepMimic clip" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()  # nothing written for a bad list
    assert main(["experts", "table", str(tmp_path / "none")]) == 2
    assert "no such experts directory" in capsys.readouterr().err
