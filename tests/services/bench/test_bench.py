"""`sfv bench`: the env suite end to end with --quick, and the command's input checks."""
from __future__ import annotations

import json
import math
import statistics

import pytest

from services.cli import main

ENV_METRICS = ("raw_steps_per_s", "env_steps_per_s", "worker_steps_per_s",
               "raw_steps_per_cpu_s", "env_steps_per_cpu_s", "worker_steps_per_cpu_s")
ENV_RATIOS = {"env_over_raw": ("env_steps_per_s", "raw_steps_per_s"),
              "worker_over_raw": ("worker_steps_per_s", "raw_steps_per_s"),
              "env_over_raw_cpu": ("env_steps_per_cpu_s", "raw_steps_per_cpu_s"),
              "worker_over_raw_cpu": ("worker_steps_per_cpu_s", "raw_steps_per_cpu_s")}


@pytest.fixture(scope="module")
def env_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench") / "env.json"
    code = main(["bench", "--suite", "env", "--quick", "--quiet", "--out", str(out)])
    return code, out


def test_quick_env_suite_writes_the_report(env_report, capsys):
    code, out = env_report
    assert code == 0
    assert [p.name for p in out.parent.iterdir()] == ["env.json"], "a temporary file was left behind"
    report = json.loads(out.read_text())
    assert report["quick"] is True and list(report["suites"]) == ["env"]
    assert report["command"].startswith("sfv bench --suite env --quick")
    suite = report["suites"]["env"]
    assert set(suite["metrics"]) == set(ENV_METRICS) and set(suite["ratios"]) == set(ENV_RATIOS)
    assert suite["settings"]["physics_hz"] == 300.0 and suite["settings"]["substeps"] == 10


def test_summaries_are_consistent(env_report):
    suite = json.loads(env_report[1].read_text())["suites"]["env"]
    repeats = suite["settings"]["repeats"]
    for name in ENV_METRICS:
        m = suite["metrics"][name]
        assert len(m["runs"]) == repeats == 3
        assert all(math.isfinite(v) and v > 0 for v in m["runs"]), name
        assert m["min"] <= m["median"] <= m["max"], name
        assert (m["min"], m["median"], m["max"]) == (min(m["runs"]), statistics.median(m["runs"]), max(m["runs"]))


def test_ratios_are_ratios_of_the_medians(env_report):
    suite = json.loads(env_report[1].read_text())["suites"]["env"]
    metrics = suite["metrics"]
    for name, (top, bottom) in ENV_RATIOS.items():
        r = suite["ratios"][name]
        assert (r["numerator"], r["denominator"]) == (top, bottom)
        assert r["value"] == pytest.approx(metrics[top]["median"] / metrics[bottom]["median"], rel=1e-12)
        paired = [t / b for t, b in zip(metrics[top]["runs"], metrics[bottom]["runs"])]
        assert r["per_repetition"]["runs"] == pytest.approx(paired, rel=1e-12)
        assert r["per_repetition"]["min"] <= r["per_repetition"]["median"] <= r["per_repetition"]["max"]
    worker = suite["ratios"]["worker_over_raw"]
    assert worker["target"] == 0.85 and worker["meets_target"] == (worker["value"] >= 0.85)


def test_bad_suite_exits_2_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "bad.json"
    assert main(["bench", "--suite", "bogus", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("sfv: --suite 'bogus': unknown suite 'bogus'; choose from env, worker, learner, system, peer, pose")
    assert len(err.strip().splitlines()) == 1
    assert not out.exists()


@pytest.mark.parametrize("out_name, message", [("missing/r.json", "does not exist"), ("r.txt", "must be a .json file")])
def test_bad_out_path_exits_2(tmp_path, capsys, out_name, message):
    assert main(["bench", "--suite", "env", "--quick", "--out", str(tmp_path / out_name)]) == 2
    assert message in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_physics_rate_must_fit_the_control_rate(tmp_path, capsys):
    assert main(["bench", "--suite", "env", "--physics-hz", "250", "--out", str(tmp_path / "r.json")]) == 2
    assert "sfv: --physics-hz: physics_hz (250.0) must be a whole multiple of control_hz (30.0)" in capsys.readouterr().err


def test_system_suite_on_the_processes_runner_reports_each_worker_count(tmp_path):
    """The end-to-end training loop without Ray: spawned worker processes, the real learner."""
    out = tmp_path / "system.json"
    assert main(["bench", "--suite", "system", "--quick", "--quiet", "--repeats", "1", "--system-runners", "processes",
                 "--out", str(out)]) == 0
    suite = json.loads(out.read_text())["suites"]["system"]
    assert suite["settings"]["system_runners"] == ["processes"]
    metrics, ratios = suite["metrics"], suite["ratios"]
    assert set(ratios) == {"system_processes_1w_over_raw", "system_processes_2w_over_raw"}
    for workers in (1, 2):
        stem = f"system_processes_{workers}w"
        overall, sampling = metrics[f"{stem}_samples_per_s"]["median"], metrics[f"{stem}_sampling_samples_per_s"]["median"]
        assert 0 < overall < sampling  # the loop's wall time includes the updates that sampling's does not
        assert ratios[f"{stem}_over_raw"]["value"] == pytest.approx(overall / (workers * metrics["raw_steps_per_s"]["median"]))
    assert "system_2w_samples_per_s" not in metrics  # no Ray run was asked for


def test_an_unknown_system_runner_is_a_one_line_error(tmp_path, capsys):
    assert main(["bench", "--suite", "system", "--system-runners", "ray,threads", "--out", str(tmp_path / "s.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert "--system-runners 'ray,threads'" in err and "\n" not in err
    assert list(tmp_path.iterdir()) == []
