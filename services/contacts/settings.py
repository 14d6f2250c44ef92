"""What the contact network's training is made of, and the shipped files' names; no torch
here, so the CLI and the ONNX inference can read it without importing torch."""
from __future__ import annotations

from dataclasses import dataclass

HELD_OUT = ("run", "jump", "kick")
MODEL_FILE, DIGEST_FILE, REPORT_FILE = "foot_contact.onnx", "foot_contact.sha256", "foot_contact.json"


@dataclass(frozen=True)
class TrainSettings:
    epochs: int = 10
    cameras_per_clip: int = 16
    batch_size: int = 64
    learning_rate: float = 1e-4
    # The shipped model's seed. Without held poses seed 0 scored 0.865 held out but 0.645 on Pose2Sim
    # and seed 1 0.850 and 0.73; with them seed 1 scores 0.894 held out and 0.81 on Pose2Sim (the four
    # cameras' mean, label flips undone as the reconstruction does: cam01 .815, cam02 .625, cam03 .895,
    # cam04 .905; before .695, .725, .805, .87).
    seed: int = 1
    held_out: tuple[str, ...] = HELD_OUT
