"""TRC marker files (OpenSim / Pose2Sim): marker names and their positions per frame."""
from __future__ import annotations

from pathlib import Path

import numpy as np


def read_trc(path: Path) -> tuple[list[str], np.ndarray]:
    """Marker names and (T, M, 3) positions in the calibration's world frame (metres, z up)."""
    lines = Path(path).read_text().splitlines()
    names = [n for n in lines[3].split("\t")[2:] if n]
    rows = [line.split("\t") for line in lines[5:] if line.strip()]
    data = np.array([[float(v) for v in row[2:2 + 3 * len(names)]] for row in rows]).reshape(len(rows), len(names), 3)
    return names, data[..., [2, 0, 1]]  # the .trc's axes are permuted against the calibration's world


def read_trc_markers(path: Path, names: tuple[str, ...]) -> np.ndarray:
    """(T, len(names), 3) positions of the named markers."""
    markers, positions = read_trc(path)
    return positions[:, [markers.index(n) for n in names]]
