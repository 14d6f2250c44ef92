"""`sfv bench --suite learning`: a tiny grid end to end (serial workers), its rerun, resume and input checks."""
from __future__ import annotations

import contextlib
import io
import json
import subprocess
import sys
import time
from pathlib import Path

import pytest

from services.cli import main

pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")

REPO = Path(__file__).resolve().parents[3]
RUNS = ("walk_asi_s0", "walk_rsi_s0")
FLAGS = ["--serial", "--workers", "1", "--envs-per-worker", "4", "--batch-size", "256", "--minibatch-size", "64",
         "--samples", "600", "--eval-every", "600", "--eval-episodes", "2", "--final-episodes", "4", "--skills", "deepmimic:walk", "--inits", "asi,rsi", "--quiet"]


def bench(out_dir: Path, *extra: str) -> tuple[int, str, float]:
    stdout = io.StringIO()
    start = time.perf_counter()
    with contextlib.redirect_stdout(stdout):
        code = main(["bench", "--suite", "learning", "--out-dir", str(out_dir), *FLAGS, *extra])
    return code, stdout.getvalue(), time.perf_counter() - start


def checkpoints(out_dir: Path) -> dict[str, int]:
    return {str(p.relative_to(out_dir)): p.stat().st_mtime_ns for p in sorted((out_dir / "runs").glob("*/checkpoint_*.pt"))}


@pytest.fixture(scope="module")
def grid(tmp_path_factory):
    out_dir = tmp_path_factory.mktemp("learning") / "out"
    code, stdout, seconds = bench(out_dir)
    return out_dir, code, stdout, seconds


def test_grid_writes_runs_figures_curves_and_plot(grid):
    out_dir, code, stdout, seconds = grid
    assert code == 0, stdout
    doc = json.loads((out_dir / "learning.json").read_text())
    assert doc["format"] == "sfv-learning-1" and doc["command"].startswith("sfv bench --suite learning")
    assert set(doc["runs"]) == set(RUNS)
    for name, init in zip(RUNS, ("asi", "rsi")):
        run = doc["runs"][name]
        assert (run["status"], run["skill"], run["init"], run["seed"]) == ("complete", "deepmimic:walk", init, 0)
        assert run["config"]["samples"] == 600 and run["config"]["batch_size"] == 256 and run["config"]["serial"] is True
        assert run["samples"] >= 600 and run["wall_s"] > 0 and run["samples_per_s"] == pytest.approx(run["samples"] / run["wall_s"])
        assert run["resumes"] == 0 and (out_dir / run["run_dir"] / "config.json").is_file()
        ev = run["eval"]
        assert ev["episodes"] == 4 and 0.0 <= ev["normalized_return"] <= 1.0 and 0.0 <= ev["fall_rate"] <= 1.0
        assert ev["episode_length"] > 0
        train = run["curve"]["train"]
        assert train["samples"] == sorted(train["samples"]) and train["samples"][-1] == run["samples"]
        assert len(train["normalized_return"]) == len(train["samples"]) >= 2
        evals = run["curve"]["eval"]  # the trainer's eval/ rows: every --eval-every samples and at the end
        assert evals["samples"] and evals["samples"][-1] == run["samples"] and evals["eval/episodes"][-1] == 2
        assert len(evals["eval/normalized_return"]) == len(evals["samples"]) and run["threshold_source"] == "eval"
        assert run["samples_to_threshold"] is None or run["samples_to_threshold"] <= run["samples"]
    assert (out_dir / "learning.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(out_dir.glob(".*.tmp")), "a temporary file was left behind"
    lines = stdout.splitlines()
    finished = [line for line in lines if line.startswith("deepmimic:walk ")]
    assert [line.split(":", 2)[1] for line in finished] == ["walk asi seed 0", "walk rsi seed 0"]
    assert all("eval NR" in line and "fall rate" in line and "min" in line for line in finished)
    assert "| deepmimic:walk | asi | 1 |" in stdout and "| deepmimic:walk | rsi | 1 |" in stdout


def test_rerun_skips_complete_runs(grid):
    out_dir = grid[0]
    before_ckpt, before = checkpoints(out_dir), json.loads((out_dir / "learning.json").read_text())
    code, stdout, seconds = bench(out_dir)
    assert code == 0
    after = json.loads((out_dir / "learning.json").read_text())
    assert checkpoints(out_dir) == before_ckpt and before_ckpt
    for name in RUNS:
        assert after["runs"][name]["wall_s"] == before["runs"][name]["wall_s"]
        assert after["runs"][name]["finished"] == before["runs"][name]["finished"]
    assert not [line for line in stdout.splitlines() if line.startswith("deepmimic:walk ")]
    assert seconds < grid[3], "the rerun took as long as training"


def test_run_without_a_record_resumes_from_its_checkpoint(grid):
    out_dir = grid[0]
    path = out_dir / "learning.json"
    doc = json.loads(path.read_text())
    lost = doc["runs"].pop("walk_rsi_s0")  # as if killed after the last checkpoint, before the record
    path.write_text(json.dumps(doc))
    before_ckpt = checkpoints(out_dir)
    code, stdout, _ = bench(out_dir)
    assert code == 0
    run = json.loads(path.read_text())["runs"]["walk_rsi_s0"]
    assert run["status"] == "complete" and run["resumes"] == 1 and run["samples"] == lost["samples"]
    assert checkpoints(out_dir) == before_ckpt, "a checkpoint was rewritten: the run trained again"
    finished = [line for line in stdout.splitlines() if line.startswith("deepmimic:walk ")]
    assert len(finished) == 1 and finished[0].startswith("deepmimic:walk rsi seed 0:")


@pytest.mark.parametrize("flags, flag", [(["--inits", "asi,xsi"], "--inits"), (["--samples", "0"], "--samples"),
                                         (["--skills", "deepmimic:nope"], "--skills"),
                                         (["--serial", "--runner", "processes"], "--serial")])
def test_bad_flags_exit_2_and_write_nothing(tmp_path, capsys, flags, flag):
    out_dir = tmp_path / "out"
    assert main(["bench", "--suite", "learning", "--out-dir", str(out_dir), *flags]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"sfv: {flag}") and len(err.splitlines()) == 1, err
    assert not out_dir.exists()


def test_script_calls_the_same_command(tmp_path):
    out_dir = tmp_path / "out"
    done = subprocess.run([sys.executable, str(REPO / "bench" / "scripts" / "learning.py"), "--out-dir", str(out_dir), "--inits", "bogus"],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert done.returncode == 2 and "--inits 'bogus'" in done.stderr and not out_dir.exists()


def test_threshold_and_plot_from_eval_rows(tmp_path):
    """The eval/ rows path (the trainer writes them every --eval-every samples): curve, first crossing, plot."""
    from services.bench.learning_report import markdown_table, minutes_to_threshold, plot, read_curve, samples_to_threshold

    rows = [{"samples": 4096 * i, "normalized_return": 0.1 * i, "time": 100.0 + 2.0 * i, "samples_per_s": 2048.0} for i in range(1, 6)]
    rows[1]["eval/normalized_return"], rows[1]["eval/fall_rate"] = 0.5, 0.4
    rows.append({"samples": 4096 * 5, "eval/normalized_return": 0.85, "eval/fall_rate": 0.0, "time": 130.0})  # an eval row of its own
    (tmp_path / "metrics.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    curve = read_curve(tmp_path)
    assert curve["eval"] == {"samples": [8192, 20480], "wall_s": [4.0, 30.0], "eval/fall_rate": [0.4, 0.0],
                             "eval/normalized_return": [0.5, 0.85]}
    assert curve["train"]["wall_s"] == [2.0, 4.0, 6.0, 8.0, 10.0]
    assert len(curve["train"]["samples"]) == 5
    assert samples_to_threshold(curve, 20480, 0.7, 0.8) == (20480, "eval")
    no_eval = {"train": curve["train"], "eval": {"samples": []}}
    assert samples_to_threshold(no_eval, 20480, 0.9, 0.8) == (20480, "train_smoothed")
    assert samples_to_threshold(no_eval, 20480, 0.2, 0.8) == (None, "train_smoothed")
    entry = {"skill": "deepmimic:run", "init": "asi", "seed": 0, "status": "complete", "samples": 20480,
             "eval": {"normalized_return": 0.85, "fall_rate": 0.0}, "curve": curve, "samples_to_threshold": 20480}
    doc = {"threshold": 0.8, "runs": {"run_asi_s0": entry, "run_rsi_s0": {**entry, "init": "rsi", "samples_to_threshold": None}}}
    table = markdown_table(doc)
    assert "| deepmimic:run | asi | 1 | 20,480 | - | 0.850 | 0.00 | 20,480 (0.5 min) |" in table
    assert "| deepmimic:run | rsi | 1 | 20,480 | - | 0.850 | 0.00 | not reached |" in table
    counted = {**entry, "wall_s": 90.0, "eval": {"normalized_return": 0.85, "fall_rate": 0.09375, "episodes": 32}}
    assert "| deepmimic:run | asi | 1 | 20,480 | 1.5 | 0.850 | 3 / 32 | 20,480 (0.5 min) |" in markdown_table({"threshold": 0.8, "runs": {"r": counted}})
    assert plot(doc, tmp_path / "p.png").read_bytes()[:4] == b"\x89PNG"
    untimed = {**entry, "curve": {**curve, "eval": {"samples": [61440], "wall_s": [None]}}}
    timed = {**untimed, "samples_to_threshold": 61440, "samples_per_s": 512.0}  # 120 s at its own rate
    assert "| 61,440 (2.0 min) |" in markdown_table({"threshold": 0.8, "runs": {"run_asi_s0": timed}})
    stamped = {**entry, "samples_per_s": 512.0}  # crossed at the eval row stamped 30 s: its time, not samples / rate
    assert minutes_to_threshold(stamped) == pytest.approx(0.5)


def test_all_skills_means_every_deepmimic_clip():
    import argparse

    from actors.motion.formats.io import DEEPMIMIC_CLIPS
    from services.bench.learning_suite import add_arguments, config_from_args

    parser = argparse.ArgumentParser()
    add_arguments(parser)
    args = parser.parse_args(["--out-dir", "unused", "--skills", "all", "--inits", "rsi"])
    args.out, args.device, args.torch_threads, args.physics_hz = None, None, None, None
    config = config_from_args(args)
    assert config.skills == tuple(DEEPMIMIC_CLIPS) and len(config.skills) == 15


def test_two_invocations_sharing_an_out_dir_keep_each_others_runs(tmp_path):
    """Two streams of clips on two cores write one learning.json: a record keeps the other's runs."""
    from services.bench.learning_suite import Cell, LearningConfig, _save

    config = LearningConfig(out_dir=tmp_path)
    first, second = Cell("deepmimic:jump", "jump", "asi", 0), Cell("deepmimic:spin", "spin", "asi", 0)
    doc_a, doc_b = {"format": "sfv-learning-1", "runs": {}}, {"format": "sfv-learning-1", "runs": {}}  # both read an empty file
    _save(doc_a, first, {"name": first.name, "status": "incomplete"}, config)
    _save(doc_b, second, {"name": second.name, "status": "complete"}, config)
    _save(doc_a, first, {"name": first.name, "status": "complete"}, config)
    runs = json.loads((tmp_path / "learning.json").read_text())["runs"]
    assert {name: run["status"] for name, run in runs.items()} == {"jump_asi_s0": "complete", "spin_asi_s0": "complete"}


def test_the_runner_flag_reaches_every_run_and_the_recorded_command(tmp_path):
    import argparse

    from services.bench import learning_suite as suite

    parser = argparse.ArgumentParser()
    suite.add_arguments(parser)
    args = parser.parse_args(["--out-dir", str(tmp_path / "out"), "--skills", "walk", "--inits", "rsi", "--runner", "processes"])
    config = suite.config_from_args(args)
    train = suite.train_config(config, suite.cells(config)[0])
    assert train.runner == "processes" and not train.serial
    assert "--runner processes" in suite.command_line(config)
    serial = suite.config_from_args(parser.parse_args(["--out-dir", str(tmp_path / "out"), "--skills", "walk", "--serial"]))
    assert suite.train_config(serial, suite.cells(serial)[0]).runner == "in_process"
    assert "--runner" not in suite.command_line(serial)


def _learning_config(tmp_path, *flags):
    import argparse

    from services.bench import learning_suite as suite

    parser = argparse.ArgumentParser()
    suite.add_arguments(parser)
    parser.add_argument("--envs-per-worker", default=None)  # `sfv bench` shares it between its suites
    args = parser.parse_args(["--out-dir", str(tmp_path / "out"), "--inits", "asi", *flags])
    return suite.config_from_args(args)


def test_a_skill_budget_overrides_samples_for_its_runs_and_their_eval_cadence(tmp_path):
    from services.bench import learning_suite as suite

    config = _learning_config(tmp_path, "--skills", "walk@1M,backflip@20M,run", "--samples", "3M")
    budgets = {cell.clip: cell.samples for cell in suite.cells(config)}
    assert budgets == {"walk": 1_000_000, "backflip": 20_000_000, "run": 3_000_000}
    trains = {cell.clip: suite.train_config(config, cell) for cell in suite.cells(config)}
    assert trains["backflip"].samples == 20_000_000 and trains["walk"].samples == 1_000_000
    assert (trains["walk"].eval_every, trains["backflip"].eval_every) == (100_000, suite.EVAL_EVERY_MAX)
    assert "walk@1M,backflip@20M,run" in suite.command_line(config)


@pytest.mark.parametrize("skills, says", [("walk@", "budget after '@'"), ("walk@lots", "budget after '@'"),
                                          ("@2M", "no motion"), ("walk,walk@2M", "taken twice")])
def test_bad_skill_budgets_name_the_entry(tmp_path, skills, says):
    from learner.errors import SfvError

    with pytest.raises(SfvError, match=says):
        _learning_config(tmp_path, "--skills", skills)


def test_a_run_moved_in_with_other_settings_is_refused_and_one_with_the_same_is_recorded(tmp_path):
    """A `sfv train` run moved into OUT_DIR/runs/: refused, naming the setting, when it learned under
    other settings; otherwise continued to the budget, evaluated, and timed from its own metrics."""
    from learner.errors import SfvError
    from services.bench import learning_suite as suite

    out_dir = tmp_path / "out"
    moved = out_dir / "runs" / "walk_asi_s0"
    flags = FLAGS[:FLAGS.index("--inits")] + ["--inits", "asi", "--quiet"]
    trained = main(["train", "--motion", "deepmimic:walk", "--out", str(moved), "--runner", "in_process", "--workers", "1",
                    "--envs-per-worker", "4", "--samples", "600", "--eval-every", "600", "--eval-episodes", "2",
                    "--ppo.batch-size", "256", "--ppo.minibatch-size", "64", "--env.sfv.tracking-termination-m", "0.5"])
    assert trained == 0
    config = _learning_config(tmp_path, *[f for f in flags if f not in ("--quiet", "--serial")], "--serial")
    with pytest.raises(SfvError, match=r"other settings: env\.sfv\.tracking_termination_m 0\.5"):
        suite.check_existing(config, suite.cells(config))
    saved = json.loads((moved / "config.json").read_text())
    saved["env"]["sfv"]["tracking_termination_m"] = suite.train_config(config, suite.cells(config)[0]).env.sfv.tracking_termination_m
    del saved["env"]["residual_scale_per_joint"]  # written before that setting: read as its trainer reads it
    (moved / "config.json").write_text(json.dumps(saved))  # as if trained at the defaults
    before = checkpoints(out_dir)
    code, stdout, _ = bench(out_dir, "--inits", "asi")
    assert code == 0, stdout
    run = json.loads((out_dir / "learning.json").read_text())["runs"]["walk_asi_s0"]
    assert run["status"] == "complete" and run["resumes"] == 1 and checkpoints(out_dir) == before
    assert run["wall_s"] > 0 and run["curve"]["eval"]["wall_s"][-1] == pytest.approx(run["curve"]["train"]["wall_s"][-1], abs=60)
