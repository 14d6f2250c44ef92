"""The pipeline's body-alone stage (`services/pipeline/body_alone.py`): the helped rollout made the
reference of a body-alone training, when it runs, and what the report says."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from learner.errors import SfvError
from services.pipeline.body_alone import helped_reference


def write_run(folder, fell_at_s=float("nan")):
    """A 60 fps reconstruction of 10 frames and a 30 Hz helped rollout of 5 control steps."""
    frames, steps = 10, 5
    times = np.arange(frames) / 60.0
    np.savez(folder / "motion.npz", frame_times=times, fps=np.asarray(60.0), root_pos=np.zeros((frames, 3)),
             root_rot=np.tile([1.0, 0, 0, 0], (frames, 1)), joint_rot=np.tile([1.0, 0, 0, 0], (frames, 12, 1)),
             contacts=(np.arange(frames * 2).reshape(frames, 2) % 3 == 0), keypoints2d=np.arange(frames * 24.0).reshape(frames, 12, 2),
             camera_intrinsics=np.eye(3))
    rollout = np.arange(steps, dtype=float)[:, None] * np.array([0.1, 0.0, 0.0]) + np.array([0.0, 0.0, 0.9])
    np.savez(folder / "simulated.npz", frame_times=np.arange(steps) / 30.0, root_pos=rollout,
             root_rot=np.tile([0.0, 0, 0, 1.0], (steps, 1)), joint_rot=np.tile([0.0, 1.0, 0, 0], (steps, 12, 1)),
             fell_at_s=np.asarray(fell_at_s))
    return rollout


def test_the_rollout_s_poses_replace_the_reconstruction_s_at_the_control_rate(tmp_path):
    rollout = write_run(tmp_path)
    made = np.load(helped_reference(tmp_path, tmp_path / "alone"))
    source = np.load(tmp_path / "motion.npz")
    assert np.allclose(made["root_pos"], rollout) and np.allclose(made["joint_rot"][..., 1], 1.0)
    assert float(made["fps"]) == pytest.approx(30.0)
    # The per-frame fields are the reconstruction's frames nearest each control step (0, 2, 4, 6, 8);
    # the camera is kept whole.
    assert np.array_equal(made["contacts"], source["contacts"][::2])
    assert np.array_equal(made["keypoints2d"], source["keypoints2d"][::2])
    assert np.array_equal(made["camera_intrinsics"], np.eye(3))


def test_a_rollout_that_fell_is_refused(tmp_path):
    write_run(tmp_path, fell_at_s=0.05)
    with pytest.raises(SfvError, match="fell at 0.05 s"):
        helped_reference(tmp_path, tmp_path / "alone")
    assert not (tmp_path / "alone" / "motion.npz").exists()


def helped_report(fell_at_s=None, alone_fell_at_s=None, help_used=True):
    report = {"fell": fell_at_s is not None, "fell_at_s": fell_at_s, "normalized_return": 0.8}
    if help_used:
        report["without_residual_force"] = {"fell": alone_fell_at_s is not None, "fell_at_s": alone_fell_at_s,
                                            "normalized_return": 0.4}
    return report


def test_the_stage_runs_where_the_helped_controller_completes_and_the_body_alone_falls():
    from services.pipeline.body_alone import stage_decision

    needed, line = stage_decision(helped_report(alone_fell_at_s=1.234), "auto")
    assert needed and "falls at 1.23 s without its help" in line
    # Not where the body alone completes already, unless asked; never where the helped controller fell
    # (no rollout of the whole clip), where there was no help, or when turned off.
    assert not stage_decision(helped_report(), "auto")[0] and stage_decision(helped_report(), "always")[0]
    skipped = stage_decision(helped_report(fell_at_s=0.5, alone_fell_at_s=0.3), "always")
    assert not skipped[0] and "fell at 0.50 s" in skipped[1]
    assert not stage_decision(helped_report(help_used=False), "always")[0]
    assert not stage_decision(helped_report(alone_fell_at_s=1.0), "off")[0]
    with pytest.raises(SfvError, match="--body-alone: 'sometimes'"):
        stage_decision(helped_report(), "sometimes")


def test_a_controller_toppling_at_the_clip_s_end_is_not_taken_as_completing():
    """Upright by the fall rule but tipped over at the last frame (balancing cam01's body alone at 150 k:
    79 degrees): the stage runs where the helped controller topples without its help, and a stage that
    topples trains on."""
    from services.pipeline.body_alone import completes, further_samples, stage_decision

    report = helped_report()
    report["without_residual_force"]["toppling"] = True
    needed, line = stage_decision(report, "auto")
    assert needed and "reaches the clip's end, toppling without its help" in line
    topples = {"fell": False, "fell_at_s": None, "toppling": True}
    assert not completes(topples) and completes(dict(topples, toppling=False))
    assert further_samples(topples, 2_000_000, 2_000_000, 4_000_000) == 3_000_000
    # A report written before the flag existed says it in its outcome line only.
    older = {"fell": False, "outcome": "completed the clip's frames (1.67 s), but toppling at its end: the pelvis 79 degrees off"}
    assert not completes(older) and completes(dict(older, outcome="completed: upright from the first frame"))


def test_the_report_names_the_controller_the_pipeline_gives(tmp_path):
    import json

    from services.pipeline.body_alone import record_stage, stage_summary

    path = tmp_path / "report.json"
    path.write_text(json.dumps(helped_report(alone_fell_at_s=1.0)))
    alone = {"outcome": "completed: upright", "fell": False, "fell_at_s": None, "normalized_return": 0.8612,
             "run": str(tmp_path / "alone" / "train"), "files": {"report": str(tmp_path / "alone" / "report.json")},
             "joint_position_error_m": {"mean": 0.2}, "reprojection_error_px": {"simulated": {"mean": 31.9}}}
    report = record_stage(path, stage_summary(True, "the body-alone stage: training", alone))
    assert report["controller"] == ("controller: the body alone (alone/train, no help): completes the clip from its "
                                    "first frame, NR 0.861")
    assert json.loads(path.read_text())["body_alone"]["reprojection_error_px"] == 31.9
    toppling = dict(alone, outcome="completed the clip's frames (1.67 s), but toppling at its end: the pelvis 79 degrees off")
    report = record_stage(path, stage_summary(True, "the body-alone stage: training", toppling))
    assert report["controller"] == "controller: the body alone (alone/train, no help): reaches the clip's end, toppling, NR 0.861"
    # Without the stage the controller is the helped one, judged with its help at zero.
    report = record_stage(path, stage_summary(False, "off"))
    assert report["controller"] == "controller: train, with its help at zero: falls at 1.00 s, NR 0.400"


def test_a_stage_that_falls_trains_on_by_half_its_budget_up_to_the_cap():
    from services.pipeline.body_alone import further_samples, max_samples

    fell, completed = {"fell": True}, {"fell": False}
    assert max_samples(2_000_000, None) == 4_000_000 and max_samples(2_000_000, 2_000_000) == 2_000_000
    # A longer clip's default cap grows with it (a 1.67-s clip keeps twice the budget); a cap given stays.
    assert max_samples(2_000_000, None, clip_seconds=1.67) == 4_000_000
    assert max_samples(2_000_000, None, clip_seconds=9.63) > 6_000_000
    assert max_samples(2_000_000, 2_000_000, clip_seconds=9.63) == 2_000_000
    with pytest.raises(SfvError, match="--body-alone-max-samples: 1000 is below"):
        max_samples(2_000_000, 1000)
    assert further_samples(fell, 2_000_000, 2_000_000, 4_000_000) == 3_000_000
    assert further_samples(fell, 3_500_000, 2_000_000, 4_000_000) == 4_000_000  # never past the cap
    assert further_samples(fell, 4_000_000, 2_000_000, 4_000_000) is None
    assert further_samples(completed, 2_000_000, 2_000_000, 4_000_000) is None


def test_the_pipeline_stage_goes_on_from_its_checkpoint_until_the_body_alone_completes(tmp_path, monkeypatch, capsys):
    """The stage's loop with the training and the rollout faked: at 2 M samples the body alone falls, at
    3 M it completes, and the loop stops there."""
    import argparse
    import json

    from services.commands import _static_pipeline as stage

    trained = {"samples": 0}
    outcomes = {2_000_000: 3.1, 3_000_000: None}

    def fake_train(config, progress):
        assert config.env.residual_force == 0.0
        trained["samples"] = config.samples
        return True

    def fake_finish(args, out, motion, run):
        fell_at = outcomes[trained["samples"]]
        report = {"outcome": "x", "fell": fell_at is not None, "fell_at_s": fell_at, "normalized_return": 0.5,
                  "files": {"report": str(out / "report.json")}, "joint_position_error_m": {"mean": 0.1},
                  "reprojection_error_px": {"simulated": {"mean": 20.0}}}
        (out / "report.json").write_text(json.dumps(report))
        return report

    monkeypatch.setattr(stage, "_train", fake_train)
    monkeypatch.setattr(stage, "_finish", fake_finish)
    monkeypatch.setattr("services.training.run_dir.trained_samples", lambda run: trained["samples"] or None)
    monkeypatch.setattr("services.pipeline.body_alone.helped_reference", lambda run, out: (out.mkdir(parents=True), out / "motion.npz")[1])
    helped = helped_report(alone_fell_at_s=1.0)
    (tmp_path / "report.json").write_text(json.dumps(helped))
    args = argparse.Namespace(body_alone="auto", body_alone_max_samples=None, quiet=True, samples=2_000_000, config=None)
    monkeypatch.setattr(stage, "_stage_config", lambda args, motion, run, resume, residual_force=None: _Config(str(run)))
    report = stage._body_alone_stage(args, tmp_path, helped, False, 2_000_000)
    said = capsys.readouterr().out
    assert "falls at 3.10 s; training on to 3000000 samples" in said
    assert report["body_alone"]["samples"] == 3_000_000 and not report["body_alone"]["fell"]
    assert report["controller"].startswith("controller: the body alone") and "completes" in report["controller"]


def test_a_first_controller_that_falls_with_its_help_trains_on_until_it_completes(tmp_path, monkeypatch, capsys):
    """The first stage's loop (`_train_while_falling`), training and rollout faked: with its help the
    controller falls at 2 M samples and completes at 3 M; the loop stops there, under the 4 M cap."""
    import argparse

    from services.commands import _static_pipeline as stage

    trained = {"samples": 2_000_000}
    outcomes = {2_000_000: 1.7, 3_000_000: None}

    def fake_train(config, progress):
        trained["samples"] = config.samples
        return True

    def fake_finish(args, out, motion, run):
        fell_at = outcomes[trained["samples"]]
        return {"fell": fell_at is not None, "fell_at_s": fell_at}

    monkeypatch.setattr(stage, "_train", fake_train)
    monkeypatch.setattr(stage, "_finish", fake_finish)
    monkeypatch.setattr("services.training.run_dir.trained_samples", lambda run: trained["samples"])
    args = argparse.Namespace(quiet=True)
    config, report = stage._train_while_falling(args, tmp_path, tmp_path / "motion.npz", _Config(str(tmp_path / "train")),
                                                fake_finish(args, tmp_path, None, None), 2_000_000, 4_000_000,
                                                "the first controller (with its help)", "--helped-max-samples")
    said = capsys.readouterr().out
    assert "the first controller (with its help): its controller falls at 1.70 s; training on to 3000000 samples" in said
    assert config.samples == 3_000_000 and not report["fell"]


@dataclasses.dataclass(frozen=True)
class _Env:
    residual_force: float = 0.0


@dataclasses.dataclass(frozen=True)
class _Config:
    """The fields of a TrainConfig the stage's loop reads."""
    out: str
    samples: int = 2_000_000
    env: _Env = _Env()
