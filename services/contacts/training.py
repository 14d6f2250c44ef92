"""Training the contact network on `synthetic_data` and shipping it as ONNX.

movingcam (section 6): Adam at 1e-4, minibatches of 64; binary cross-entropy per foot.
Whole clips are held out (`HELD_OUT`, with their mirrors) and scored per clip, on their own
random cameras. The shipped files: `foot_contact.onnx`, `foot_contact.sha256` (its digest,
checked when it is loaded) and `foot_contact.json` (how it was made and the accuracy table).
Retrain: `sfv contacts-train --out services/contacts/weights` (the defaults made the shipped
files; about 4 minutes on two cores).
"""
from __future__ import annotations

import hashlib
import json
import time
from pathlib import Path

import numpy as np
import torch

from actors.motion.formats.io import DEEPMIMIC_CLIPS
from learner.atomic_io import atomic_output
from services.contacts.network import contact_network, export_onnx
from services.contacts.settings import DIGEST_FILE, MODEL_FILE, REPORT_FILE, TrainSettings
from services.contacts.synthetic_data import ContactDataset, make_dataset


def accuracy(network: torch.nn.Module, data: ContactDataset, mask: np.ndarray) -> float:
    network.eval()
    with torch.no_grad():
        logits = network(torch.as_tensor(data.features[mask]))
    predicted = (logits.numpy() > 0).astype(np.float32)
    return float((predicted == data.labels[mask]).mean())


def train_contact_network(settings: TrainSettings, log=print) -> tuple[torch.nn.Module, dict]:
    torch.manual_seed(settings.seed)
    train_clips = tuple(c for c in DEEPMIMIC_CLIPS if c not in settings.held_out)
    train = make_dataset(train_clips, settings.cameras_per_clip, settings.seed)
    test = make_dataset(settings.held_out, settings.cameras_per_clip, settings.seed + 1)
    network = contact_network()
    optimiser = torch.optim.Adam(network.parameters(), lr=settings.learning_rate)
    loss_fn = torch.nn.BCEWithLogitsLoss()
    features, labels = torch.as_tensor(train.features), torch.as_tensor(train.labels)
    generator = torch.Generator().manual_seed(settings.seed)
    started = time.perf_counter()
    for epoch in range(settings.epochs):
        network.train()
        order = torch.randperm(len(features), generator=generator)
        total = 0.0
        for start in range(0, len(order) - settings.batch_size + 1, settings.batch_size):
            batch = order[start:start + settings.batch_size]
            optimiser.zero_grad(set_to_none=True)
            loss = loss_fn(network(features[batch]), labels[batch])
            loss.backward()
            optimiser.step()
            total += float(loss.detach()) * len(batch)
        held = accuracy(network, test, np.ones(len(test.labels), bool))
        log(f"epoch {epoch + 1}/{settings.epochs}: loss {total / len(order):.4f}, held-out accuracy {held:.3f}, "
            f"{time.perf_counter() - started:.0f} s")
    report = {
        "settings": {**settings.__dict__, "held_out": list(settings.held_out)},
        "train_windows": int(len(train.labels)), "test_windows": int(len(test.labels)),
        "train_accuracy": accuracy(network, train, np.ones(len(train.labels), bool)),
        "held_out_accuracy": {name: accuracy(network, test, test.clip == i) for i, name in enumerate(test.clips)},
        "held_out_contact_rate": {name: float(test.labels[test.clip == i].mean()) for i, name in enumerate(test.clips)},
        "seconds": round(time.perf_counter() - started, 1),
    }
    return network, report


def save_shipped(network: torch.nn.Module, report: dict, directory: Path) -> Path:
    """Write the ONNX model, its digest and the report, each atomically."""
    directory.mkdir(parents=True, exist_ok=True)
    with atomic_output(directory / MODEL_FILE, suffix=".onnx") as tmp:
        export_onnx(network, tmp)
        digest = hashlib.sha256(tmp.read_bytes()).hexdigest()
    with atomic_output(directory / DIGEST_FILE) as tmp:
        tmp.write_text(f"{digest}  {MODEL_FILE}\n")
    with atomic_output(directory / REPORT_FILE) as tmp:
        tmp.write_text(json.dumps({**report, "sha256": digest}, indent=2) + "\n")
    return directory / MODEL_FILE
