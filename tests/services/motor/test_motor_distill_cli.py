"""`sfv distill` end to end on two tiny experts (Ray recording, training, module files), then
one-shot imitation with the module and a resumed run."""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from services.cli import main

from tests.services.motor.test_motor_dataset import random_expert  # noqa: F401  (fixture)


def tiny(updates: int) -> list[str]:
    return ["--steps-per-clip", "60", "--episode-steps", "10", "--chunk-steps", "30", "--updates", str(updates), "--window", "4",
            "--batch-windows", "8", "--encoder-hidden", "16", "--decoder-hidden", "16", "--latent-dim", "4",
            "--validation-fraction", "0.5", "--torch-threads", "1", "--quiet"]


@pytest.fixture(scope="module")
def experts(random_expert, tmp_path_factory):
    root = tmp_path_factory.mktemp("experts")
    for name in ("stand_a", "stand_b"):
        shutil.copytree(random_expert, root / name)
    return root


def test_distill_two_tiny_experts_into_a_module(experts, tmp_path, capsys):
    from learner.motor_decoder import LatentDecoder
    from services.motor.dataset import read_manifest
    from services.motor.one_shot import evaluate_clip
    from services.motor.training import load_module

    module_dir = tmp_path / "module"
    assert main(["distill", str(experts), "--out", str(module_dir), "--hold-out", "stand_b", *tiny(12)]) == 0
    out = capsys.readouterr().out
    assert "120 steps of 2 clips" in out and "trained on stand_a (12 updates" in out
    manifest = read_manifest(module_dir / "dataset")
    assert manifest["clips"] == ["stand_a", "stand_b"] and manifest["steps_per_clip"] == {"stand_a": 60, "stand_b": 60}
    for name in ("config.json", "module.pt", "decoder.npz", "decoder.onnx", "loss_curve.png", "metrics.jsonl"):
        assert (module_dir / name).is_file(), name
    record = json.loads((module_dir / "config.json").read_text())
    assert record["held_out"] == ["stand_b"] and record["clips"] == ["stand_a"] and record["module"]["latent_dim"] == 4
    latent_range = record["latent_range"]  # where the encoder puts z on the training data
    assert len(latent_range["std_per_component"]) == 4 and 0 <= latent_range["components_used"] <= 4
    assert 0 <= latent_range["abs_p50"] <= latent_range["abs_p95"] <= latent_range["abs_p99"]
    rows = [json.loads(line) for line in (module_dir / "metrics.jsonl").read_text().splitlines()]
    assert rows[-1]["update"] == 12 and "val/loss" in rows[-1] and np.isfinite(rows[-1]["loss"])
    decoder = LatentDecoder.load(module_dir)
    assert decoder(np.zeros((2, 196), np.float32), np.zeros((2, 4), np.float32)).shape == (2, 28)
    assert load_module(module_dir).config.latent_dim == 4

    figures = evaluate_clip(str(module_dir), str(experts), "stand_b", episodes=1)
    assert set(figures) >= {"expert", "one_shot", "relative_return", "relative_survival"}
    assert 0.0 <= figures["one_shot"]["normalized_return"] <= 1.0 and figures["relative_survival"] > 0

    # a longer budget continues from the checkpoint; other settings are refused
    assert main(["distill", str(experts), "--out", str(module_dir), "--hold-out", "stand_b", *tiny(16), "--resume"]) == 0
    rows = [json.loads(line) for line in (module_dir / "metrics.jsonl").read_text().splitlines()]
    assert [r["update"] for r in rows][-1] == 16 and len({r["update"] for r in rows}) == len(rows)
    assert main(["distill", str(experts), "--out", str(module_dir), "--hold-out", "stand_b", *tiny(20), "--latent-dim", "5", "--resume"]) == 2
    assert "other settings" in capsys.readouterr().err
