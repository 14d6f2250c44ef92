"""Reading a task run back: its config and its newest policy (`sfv task eval`, `sfv task render`,
the NPMP task benchmark)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from learner.checkpoint import load_checkpoint
from learner.errors import SfvError
from services.tasks.config import TaskConfig
from services.training.run_dir import CONFIG_FILE, checkpoint_files


def load_task_run(run_dir: str):
    """(TaskConfig, policy weights) of a task run's newest checkpoint."""
    path = Path(run_dir) / CONFIG_FILE
    if not path.is_file():
        raise SfvError(f"{run_dir}: not a task run directory (no {CONFIG_FILE})")
    config = TaskConfig.from_dict(json.loads(path.read_text()))
    checkpoints = checkpoint_files(Path(run_dir))
    if not checkpoints:
        raise SfvError(f"{run_dir}: no checkpoint yet")
    payload = load_checkpoint(checkpoints[-1])
    weights = {k: v.numpy() if hasattr(v, "numpy") else np.asarray(v) for k, v in payload["policy_weights"].items()}
    return config, weights
